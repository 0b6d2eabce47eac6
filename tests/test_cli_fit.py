"""`neuraltex fit` and texture files (.ntex) through every command that reads a texture,
in-process, on tiny images with the shipped default model."""

import json

import numpy as np
import pytest
import torch
from PIL import Image

from neuraltex.cli import main
from neuraltex.data.generator import generate

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("fit")
    for name, index in (("a.png", 0), ("b.png", 3)):
        pic = (generate(index, 0, (32, 40)).image * 255).round().astype(np.uint8)
        Image.fromarray(pic).save(d / name)
    assert main(["fit", str(d / "a.png"), "-o", str(d / "a.ntex"), "--steps", "60",
                 "--segmenter", "felzenszwalb", "--preview", str(d / "prev.png")]) == 0
    return d


def test_fit_writes_a_small_texture_file_and_a_preview(files, capsys):
    assert (files / "a.ntex").stat().st_size < 2 * 2**20
    with Image.open(files / "prev.png") as im:
        assert im.size == (80, 32)  # input | reconstruction


@pytest.mark.parametrize("argv", [
    ["reconstruct", "{a}", "-o", "{out}.png"],
    ["reshuffle", "{a}", "-o", "{out}_{{i}}.png", "--count", "2", "--seed", "1"],
    ["vary", "{a}", "-o", "{out}.png", "--appearance", "0.5"],
    ["transfer", "{b}", "{a}", "-o", "{out}.png"],
    ["transfer", "{a}", "{b}", "-o", "{out}.png", "--mode", "replace"],
    ["interpolate", "{a}", "{b}", "-o", "{out}.gif", "--frames", "3"],
    ["interpolate", "{a}", "{a}", "-o", "{out}.png", "--t", "0.3"],
    ["animate", "{a}", "-o", "{out}.gif", "--frames", "2"],
    ["stylize", "{b}", "{a}", "-o", "{out}.png"],
    ["vectorize", "{a}", "-o", "{out}.svg"],
    ["vectorize", "{a}", "-o", "{out}.svg", "--mode", "ellipse"],
])
def test_every_texture_command_takes_a_texture_file(files, tmp_path, argv):
    values = {"a": files / "a.ntex", "b": files / "b.png", "out": tmp_path / "out"}
    args = [a.format(**values) for a in argv]
    assert main(args) == 0
    assert list(tmp_path.iterdir())


def test_reshuffle_moves_whole_elements_of_a_texture_file(tmp_path):
    """Nine discs of nine colours: reshuffled by elements, the discs trade places (the
    picture changes, the set of disc colours does not)."""
    from neuraltex.imageio import load_image

    yy, xx = np.mgrid[0:72, 0:72]
    pic = np.full((72, 72, 3), 128, np.uint8)
    colours = [(230, 40, 40), (40, 230, 40), (40, 40, 230), (230, 230, 40), (230, 40, 230),
               (40, 230, 230), (250, 250, 250), (10, 10, 10), (200, 120, 40)]
    centres = [(12 + 24 * (i // 3), 12 + 24 * (i % 3)) for i in range(9)]
    for (cy, cx), c in zip(centres, colours, strict=True):
        pic[(yy - cy) ** 2 + (xx - cx) ** 2 <= 36] = c
    Image.fromarray(pic).save(tmp_path / "discs.png")
    ntex = tmp_path / "discs.ntex"
    assert main(["fit", str(tmp_path / "discs.png"), "-o", str(ntex), "--steps", "30",
                 "--segmenter", "felzenszwalb"]) == 0
    assert main(["reconstruct", str(ntex), "-o", str(tmp_path / "rec.png")]) == 0
    assert main(["reshuffle", str(ntex), "-o", str(tmp_path / "el.png"), "--seed", "2"]) == 0
    rec, out = load_image(tmp_path / "rec.png"), load_image(tmp_path / "el.png")
    at = lambda img: torch.stack([img[:, cy, cx] for cy, cx in centres])  # noqa: E731
    assert (out - rec).abs().amax(0).gt(0.3).float().mean() > 0.05  # discs moved
    # every disc of the reshuffle shows one of the nine colours, and not all where they were
    near = torch.cdist(at(out), at(rec))  # (9, 9)
    assert near.amin(1).max() < 0.25 and near.diagonal().max() > 0.5

    # --source: the elements move in the picture itself (its exact colours), checked
    palette = np.array([(128, 128, 128), *colours])
    exact = lambda path: float(np.mean(np.all(np.asarray(Image.open(path))[..., :3].reshape(  # noqa: E731
        -1, 1, 3) == palette[None], -1).any(1)))
    src = tmp_path / "src.png"
    assert main(["reshuffle", str(ntex), "-o", str(src), "--seed", "2",
                 "--source", str(tmp_path / "discs.png")]) == 0
    assert exact(src) > 0.85 and exact(src) > exact(tmp_path / "el.png") + 0.3
    # the reconstruction's plan, drawn in the picture: the same places change hands
    changed_src = (load_image(src) - load_image(tmp_path / "discs.png")).abs().amax(0) > 0.3
    changed_rec = (out - rec).abs().amax(0) > 0.3
    assert changed_src.float().mean() > 0.05
    assert (changed_src & changed_rec).sum() / (changed_src | changed_rec).sum() > 0.7
    Image.fromarray(pic[::-1].copy()).save(tmp_path / "other.png")
    for extra in (["--source", str(tmp_path / "other.png")],  # not the fitted picture
                  ["--source", str(tmp_path / "discs.png"), "--by", "textons"]):
        assert main(["reshuffle", str(ntex), "-o", str(tmp_path / "bad.png"), *extra]) == 2
        assert not (tmp_path / "bad.png").exists()
    assert main(["reshuffle", str(tmp_path / "discs.png"), "-o", str(tmp_path / "bad.png"),
                 "--source", str(tmp_path / "discs.png")]) == 2  # an image is its own source


def test_reshuffle_size_ratio_lets_objects_of_other_sizes_trade_places(tmp_path):
    """Eight large discs and one small one (area 0.56x): by default (1.1) the small disc never
    moves; with --size-ratio 2 it trades places with a large one for some seed."""
    from neuraltex.imageio import load_image

    yy, xx = np.mgrid[0:72, 0:72]
    pic = np.full((72, 72, 3), 128, np.uint8)
    centres = [(12 + 24 * (i // 3), 12 + 24 * (i % 3)) for i in range(9)]
    for i, (cy, cx) in enumerate(centres):
        colour = (250, 250, 250) if i == 4 else (40 + 20 * i, 200 - 15 * i, 60)
        pic[(yy - cy) ** 2 + (xx - cx) ** 2 <= (20 if i == 4 else 36)] = colour
    Image.fromarray(pic).save(tmp_path / "discs.png")
    ntex = tmp_path / "discs.ntex"
    assert main(["fit", str(tmp_path / "discs.png"), "-o", str(ntex), "--steps", "30",
                 "--segmenter", "felzenszwalb"]) == 0

    def small_disc_stays(*extra: str) -> list[bool]:
        out = tmp_path / "out_{i}.png"
        assert main(["reshuffle", str(ntex), "-o", str(out), "--count", "4", "--seed", "0",
                     *extra]) == 0
        return [load_image(tmp_path / f"out_{i}.png")[:, 36, 36].min().item() > 0.8
                for i in range(4)]

    assert all(small_disc_stays())
    assert not all(small_disc_stays("--size-ratio", "2"))


def test_texture_file_edit_list(files, tmp_path):
    edits = tmp_path / "e.json"
    edits.write_text(json.dumps([{"select": {"point": [0.5, 0.5]}, "op": "scale", "by": 1.5}]))
    assert main(["edit", str(files / "a.ntex"), str(edits), "-o", str(tmp_path / "o.png")]) == 0


def test_reconstruction_from_the_texture_file_is_the_tuned_one(files, tmp_path):
    """The tuned decoder, not the base one, renders the file's textons: its reconstruction
    is closer to the input than the base model's encode-decode."""
    main(["reconstruct", str(files / "a.ntex"), "-o", str(tmp_path / "t.png")])
    main(["reconstruct", str(files / "a.png"), "-o", str(tmp_path / "b.png")])
    src = np.asarray(Image.open(files / "a.png"), np.float32)
    tuned = np.asarray(Image.open(tmp_path / "t.png"), np.float32)
    base = np.asarray(Image.open(tmp_path / "b.png"), np.float32)
    assert ((tuned - src) ** 2).mean() < ((base - src) ** 2).mean()


def test_propagate_edits_a_texture_files_reconstruction(files, tmp_path, capsys):
    rec, edited, out = tmp_path / "rec.png", tmp_path / "edited.png", tmp_path / "out.png"
    assert main(["reconstruct", str(files / "a.ntex"), "-o", str(rec)]) == 0
    pic = np.asarray(Image.open(rec)).copy()
    pic[14:18, 18:22] = (255, 0, 255)  # a magenta dot on one texton
    Image.fromarray(pic).save(edited)
    assert main(["propagate", str(files / "a.ntex"), str(edited), "-o", str(out),
                 "--threshold", "0.5"]) == 0
    assert "propagated to" in capsys.readouterr().out
    result = np.asarray(Image.open(out)).astype(int)
    magenta = (result[..., 0] > 200) & (result[..., 1] < 60) & (result[..., 2] > 200)
    assert magenta.sum() > 16  # the dot, and copies of it elsewhere
    wide = tmp_path / "wide.png"
    Image.fromarray(np.zeros((32, 64, 3), np.uint8)).save(wide)
    assert main(["propagate", str(files / "a.ntex"), str(wide), "-o", str(out)]) == 2
    assert "aspect" in capsys.readouterr().err


def test_a_fit_without_detail_sprites_still_decodes_everywhere(files, tmp_path):
    plain = tmp_path / "plain.ntex"
    assert main(["fit", str(files / "a.png"), "-o", str(plain), "--steps", "5",
                 "--segmenter", "felzenszwalb", "--detail", "0"]) == 0
    assert plain.stat().st_size < (files / "a.ntex").stat().st_size
    # mixed with a file that has sprites: padded to one layout
    assert main(["interpolate", str(plain), str(files / "a.ntex"), "-o",
                 str(tmp_path / "mix.png"), "--t", "0.5"]) == 0
    assert main(["transfer", str(files / "a.ntex"), str(plain), "-o",
                 str(tmp_path / "tr.png")]) == 0
    # sprites of different sides (auto sizes them by texton count) are resampled to one
    small = tmp_path / "small.ntex"
    assert main(["fit", str(files / "a.png"), "-o", str(small), "--steps", "5",
                 "--segmenter", "felzenszwalb", "--detail", "4"]) == 0
    assert main(["interpolate", str(small), str(files / "a.ntex"), "-o",
                 str(tmp_path / "mix2.png"), "--t", "0.5"]) == 0
    assert main(["transfer", str(small), str(files / "a.ntex"), "-o",
                 str(tmp_path / "tr2.png"), "--mode", "replace"]) == 0


@pytest.mark.parametrize("extra, message", [
    (["--detail", "1"], "--detail"),
    (["--seconds", "0"], "--seconds"),
    (["--steps", "0"], "--steps"),
    (["--size", "8"], "--size"),
    (["--max-textons", "1"], "--max-textons"),
    (["--queries", "196"], "--queries applies to --segmenter model"),
    (["--segmenter", "model", "--queries", "0"], "--queries must lie"),
    (["--segmenter", "model", "--queries", "5000"], "--queries must lie"),
])
def test_bad_fit_arguments_are_one_line(files, tmp_path, capsys, extra, message):
    out = tmp_path / "x.ntex"
    assert main(["fit", str(files / "a.png"), "-o", str(out), *extra]) == 2
    assert message in capsys.readouterr().err and not out.exists()


def test_odd_images_fit_or_fail_cleanly(tmp_path, capsys):
    Image.new("RGB", (1, 1), (200, 10, 10)).save(tmp_path / "dot.png")
    Image.new("L", (24, 24), 128).save(tmp_path / "flat.png")
    for name in ("dot.png", "flat.png"):
        code = main(["fit", str(tmp_path / name), "-o", str(tmp_path / f"{name}.ntex"),
                     "--steps", "2"])
        err = capsys.readouterr().err
        assert code in (0, 2) and "Traceback" not in err
        assert (tmp_path / f"{name}.ntex").exists() == (code == 0)
    assert main(["fit", str(tmp_path / "flat.png"), "-o", str(tmp_path / "x.png")]) == 2


def test_tampered_texture_file_is_refused_before_any_output(files, tmp_path, capsys):
    data = bytearray((files / "a.ntex").read_bytes())
    data[-9] ^= 0x55
    bad = tmp_path / "bad.ntex"
    bad.write_bytes(bytes(data))
    out = tmp_path / "o.png"
    assert main(["reconstruct", str(bad), "-o", str(out)]) == 2
    assert "checksum" in capsys.readouterr().err and not out.exists()


def test_cvt_grows_a_texture_file(files, tmp_path):
    from cvt.cli import main as cvt_main

    out = tmp_path / "big.svg"
    assert cvt_main(["synthesize", "--from-image", str(files / "a.ntex"), "-o", str(out),
                     "--scale", "1.5", "--levels", "1", "--iterations", "1", "--quiet"]) == 0
    assert out.read_text().count("<path") > 1


@pytest.fixture(scope="module")
def b_file(files):
    b = files / "b.ntex"
    assert main(["fit", str(files / "b.png"), "-o", str(b), "--steps", "30",
                 "--segmenter", "felzenszwalb"]) == 0
    return b


def test_transfer_between_texture_files_keeps_the_structure_in_the_other_palette(
        files, b_file, tmp_path, capsys):
    """a.ntex in b.ntex's colours (--mode palette, the default for two texture files): the
    picture's colours come from b (its mean colour is b's reconstruction's, not a's), its
    layout from a (it correlates with a's reconstruction far more than b's does)."""
    b = b_file
    for name, src in (("ra.png", files / "a.ntex"), ("rb.png", b)):
        assert main(["reconstruct", str(src), "-o", str(tmp_path / name)]) == 0
    assert main(["transfer", str(files / "a.ntex"), str(b), "-o", str(tmp_path / "t.png")]) == 0
    load = lambda n: np.asarray(Image.open(tmp_path / n), np.float64) / 255  # noqa: E731
    ra, rb, t = load("ra.png"), load("rb.png"), load("t.png")
    mean = lambda x: x.reshape(-1, 3).mean(0)  # noqa: E731
    assert np.abs(mean(t) - mean(rb)).max() < 0.5 * np.abs(mean(ra) - mean(rb)).max()
    luma = lambda x: (x @ [0.299, 0.587, 0.114]).ravel()  # noqa: E731
    corr = lambda x, y: np.corrcoef(luma(x), luma(y))[0, 1]  # noqa: E731
    assert corr(t, ra) > 0.8 and corr(t, ra) > corr(rb, ra) + 0.3
    assert main(["transfer", str(files / "a.ntex"), str(files / "b.png"), "-o",
                 str(tmp_path / "x.png"), "--mode", "palette"]) == 2
    assert "texture files" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def test_interpolation_between_texture_files_runs_from_one_to_the_other(files, b_file,
                                                                        tmp_path):
    """At t = 0 the picture is a's reconstruction, at t = 1 b's (rendered at a's size), in
    between the mean colour lies between theirs; --frames and --spatial run the same way."""
    a = str(files / "a.ntex")
    for name, src in (("ra.png", a), ("rb.png", str(b_file))):
        assert main(["reconstruct", src, "-o", str(tmp_path / name)]) == 0
    for t in ("0", "0.5", "1"):
        assert main(["interpolate", a, str(b_file), "-o", str(tmp_path / f"t{t}.png"),
                     "--t", t]) == 0
    load = lambda n: np.asarray(Image.open(tmp_path / n), np.float64) / 255  # noqa: E731
    ra, rb = load("ra.png"), load("rb.png")
    assert np.abs(load("t0.png") - ra).max() < 2 / 255
    assert np.abs(load("t1.png") - rb).max() < 2 / 255
    m = load("t0.5.png").reshape(-1, 3).mean(0)
    lo, hi = np.minimum(ra.reshape(-1, 3).mean(0), rb.reshape(-1, 3).mean(0)), np.maximum(
        ra.reshape(-1, 3).mean(0), rb.reshape(-1, 3).mean(0))
    assert ((m > lo - 0.02) & (m < hi + 0.02)).all()
    assert main(["interpolate", a, str(b_file), "-o", str(tmp_path / "f.gif"),
                 "--frames", "3"]) == 0
    assert main(["interpolate", a, str(b_file), "-o", str(tmp_path / "s.png"),
                 "--spatial"]) == 0
    s = load("s.png")
    assert np.abs(s[:, 0] - ra[:, 0]).max() < 2 / 255
    assert np.abs(s[:, -1] - rb[:, -1]).max() < 2 / 255


def test_texture_edit_benchmark_times_every_command(files, capsys):
    """scripts/bench_texture_edits.py runs each editing command on the texture file through
    the real CLI and prints a row per command."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
    try:
        import bench_texture_edits
    finally:
        sys.path.pop(0)
    assert bench_texture_edits.main([str(files / "a.ntex"), "--repeat", "1"]) == 0
    table = capsys.readouterr().out
    for name in ("reconstruct", "reshuffle", "vary", "edit", "transfer", "interpolate",
                 "interpolate --spatial", "animate --frames 8", "vectorize"):
        assert f"| {name} |" in table, name
