"""`cvt synthesize --from-image`: raster image -> texton elements -> vector synthesis."""

from pathlib import Path

import numpy as np
import pytest
import torch
from PIL import Image

from cvt.cli import main
from cvt.from_textons import image_exemplar, with_backdrop
from cvt.sampling import sample_exemplar
from cvt.svg import parse_svg
from cvt.synthesis import SynthesisConfig, feature_table


def _discs(path, size: int = 48) -> None:
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    img = np.full((size, size, 3), 0.45)
    rng = np.random.default_rng(1)
    for x, y in rng.uniform(5, size - 5, (9, 2)):
        colour = (0.9, 0.2, 0.1) if x < size / 2 else (0.1, 0.3, 0.9)
        img[(xx - x) ** 2 + (yy - y) ** 2 < 16] = colour
    Image.fromarray((img * 255).astype(np.uint8)).save(path)


FAST = ["--scale", "1.5", "--levels", "1", "--iterations", "2", "--quiet"]


@pytest.mark.slow
@pytest.mark.parametrize("segmenter", ["felzenszwalb", "model"])
def test_from_image_end_to_end(tmp_path, tiny_checkpoint, segmenter):
    _discs(tmp_path / "in.png")
    out, ex = tmp_path / "out.svg", tmp_path / "ex.svg"
    args = ["synthesize", "--from-image", str(tmp_path / "in.png"), "-o", str(out),
            "--exemplar-out", str(ex), "--segmenter", segmenter, *FAST]
    if segmenter == "model":  # the untrained model's few huge, overlapping segments would
        # make the clustering step take a minute; the plumbing is the same without it
        args += ["--checkpoint", tiny_checkpoint, "--method", "no-clustering"]
    assert main(args) == 0
    exemplar = parse_svg(ex.read_bytes())
    result = parse_svg(out.read_bytes())
    assert exemplar.viewbox == (0, 0, 48, 48) and result.viewbox == (0, 0, 72, 72)
    first = result.background[0].node  # the backdrop rectangle, under everything
    assert first.tag.endswith("rect") and first.get("width") == "72"
    assert len(result.elements) >= 1


def test_backdrop_and_kinds_as_appearance(tmp_path):
    from neuraltex.segments import from_labels
    from neuraltex.vectorize import VectorizeParams, to_svg, vectorize

    _discs(tmp_path / "in.png")
    img = np.asarray(Image.open(tmp_path / "in.png"), dtype=np.float64) / 255
    labels = np.zeros(img.shape[:2], np.int64)
    labels[:, 24:] = 1
    labels[img[..., 0] > 0.8] = 2  # red discs
    labels[img[..., 2] > 0.8] = 3  # blue discs
    from neuraltex.segments import drop_background

    seg = drop_background(from_labels(labels, img), 0.1)
    svg = to_svg(vectorize(img, seg, VectorizeParams(kinds=2)), seg)
    ie = image_exemplar(svg)
    assert all(e.node.get("data-background") != "1" for e in ie.exemplar.elements)
    assert ie.exemplar.appearance.shape == (len(ie.exemplar.elements), 2)
    inp = sample_exemplar(ie.exemplar, 3.0)
    cfg = SynthesisConfig()
    app = torch.as_tensor(ie.exemplar.appearance)
    plain = feature_table(inp, inp, None, cfg)
    table = feature_table(inp, inp, app, cfg)
    kind = app.argmax(1)[inp.element]
    differ = kind[:, None] != kind[None, :]
    assert torch.allclose((table - plain)[differ], torch.tensor(2 * 1.0 / 5, dtype=table.dtype))
    assert torch.equal(table[~differ], plain[~differ])
    text = with_backdrop('<svg xmlns="http://www.w3.org/2000/svg" viewBox="1 2 30 40"/>', "#123456")
    rect = parse_svg(text.encode()).background[0].node
    assert rect.get("fill") == "#123456" and rect.get("x") == "1" and rect.get("height") == "40"


@pytest.mark.parametrize("args", [
    ["--from-image", "missing.png"],
    ["--from-image", "bad.png"],
    ["--from-image", "in.png", "ex.svg"],  # both an exemplar and an image
    [],  # neither
    ["--from-image", "in.png", "--w-a", "-1"],
])
def test_from_image_bad_input_exits_2(tmp_path, capsys, monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    _discs(tmp_path / "in.png")
    (tmp_path / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\nnope")
    (tmp_path / "ex.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 9 9">'
                                     '<rect width="2" height="2"/></svg>')
    code = main(["synthesize", *args, "-o", "out.svg", "--segmenter", "felzenszwalb", *FAST])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("cvt: error:") and len(err.splitlines()) == 1
    assert not (tmp_path / "out.svg").exists()


def test_gaussian_init_copies_whole_elements_without_stacking():
    from cvt.initialization import element_gaussians, gaussian_init
    from cvt.svg import load_svg

    inp = sample_exemplar(load_svg(Path(__file__).parents[1] / "cvt/exemplars/stars.svg"), 10.0)
    ids, mu, cov = element_gaussians(inp)
    one = inp.cluster == ids[0]
    assert torch.allclose(mu[0], inp.pos[one].mean(0))
    assert torch.allclose(cov[0], torch.cov(inp.pos[one].T, correction=0), atol=1e-4)
    x0, y0, w, h = 0, 0, 200, 200
    out = gaussian_init(inp, (x0, y0, w, h), (0, 0, 2 * w, 2 * h), 60.0,
                        torch.Generator().manual_seed(0))
    full = torch.bincount(inp.cluster)[inp.cluster[out.source]]
    have = torch.bincount(out.cluster)[out.cluster]
    inner = out.pos.max(1).values < 2 * w - 30  # clusters away from the clipped far sides
    assert torch.equal(full[inner], have[inner])  # whole elements, never cut by patch borders
    centres = torch.stack([out.pos[out.cluster == c].mean(0) for c in out.cluster.unique()])
    assert torch.pdist(centres).min() > 1.0  # no two copies stacked on one centre


def _tiled_discs(path, tile: int = 16, reps: int = 4) -> np.ndarray:
    """A tile with a red and a blue disc on grey, repeated reps x reps times."""
    yy, xx = np.mgrid[0:tile, 0:tile] + 0.5
    t = np.full((tile, tile, 3), 0.45)
    t[(xx - 5) ** 2 + (yy - 5) ** 2 < 9] = (0.9, 0.2, 0.1)
    t[(xx - 11) ** 2 + (yy - 11) ** 2 < 6] = (0.1, 0.3, 0.9)
    pic = np.tile(t, (reps, reps, 1))
    Image.fromarray((pic * 255).astype(np.uint8)).save(path)
    return pic


def _colourful(element) -> bool:
    fill = next(n.get("fill") for n in element.node.iter() if n.get("fill"))
    rgb = [int(fill[i:i + 2], 16) for i in (1, 3, 5)] if fill.startswith("#") else [0, 0, 0]
    return max(rgb) - min(rgb) > 100


def test_from_image_of_a_tiled_picture_keeps_its_lattice(tmp_path, capsys):
    """The picture's lattice (neuraltex.raster_lattice) reaches cvt: the output is tiled with
    its cells (cvt.lattice.cell_copies), so every disc of the output sits one period from
    another; --no-lattice runs the seed's method instead."""
    _tiled_discs(tmp_path / "in.png")
    out = tmp_path / "out.svg"
    base = ["synthesize", "--from-image", str(tmp_path / "in.png"), "--segmenter",
            "felzenszwalb", "--scale", "2", "--levels", "1", "--iterations", "1"]
    assert main([*base, "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "lattice of the picture: periods" in err
    result = parse_svg(out.read_bytes())
    assert result.viewbox == (0, 0, 128, 128)
    centres = np.array([(e.bbox[:2] + e.bbox[2:]) / 2 for e in result.elements
                        if _colourful(e)])  # the discs (the grey ground's pieces vary by cell)
    inner = centres[(centres > 20).all(1) & (centres < 108).all(1)]
    assert len(inner) >= 40  # about two discs a cell
    for c in inner:  # the disc one period to the right is there: the grid is kept
        assert np.min(np.linalg.norm(centres - (c + [16, 0]), axis=1)) < 0.5
    assert main([*base, "-o", str(tmp_path / "free.svg"), "--no-lattice", "--method",
                 "no-clustering"]) == 0
    assert "lattice of the picture" not in capsys.readouterr().err


def test_a_given_lattice_tiles_cells_and_snaps_a_tileable_size():
    from cvt.pattern import PatternOptions, synthesize_pattern

    doc = ('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 40 40">'
           + "".join(f'<circle cx="{5 + 10 * i}" cy="{5 + 10 * j}" r="2"/>'
                     for i in range(4) for j in range(4)) + "</svg>").encode()
    ex = parse_svg(doc)
    opts = PatternOptions(basis=np.array([[10.0, 0.0], [0.0, 10.0]]), tileable=True)
    pattern = synthesize_pattern(ex, (63.0, 50.0), SynthesisConfig(levels=1, iterations=1),
                                 "no-clustering", opts)
    assert pattern.size == (60.0, 50.0)  # snapped to whole periods
    assert any("snapped" in n for n in pattern.notes)
    assert any("lattice of the picture" in n for n in pattern.notes)
    c = np.array([(ex.elements[e].bbox[:2] + ex.elements[e].bbox[2:]) / 2 + [dx, dy]
                  for e, dx, dy in pattern.placements])
    on = c[(c[:, 0] > 0) & (c[:, 0] < 60) & (c[:, 1] > 0) & (c[:, 1] < 50)]
    assert len(on) == 30 and len(np.unique(on.round(6), axis=0)) == 30  # one per cell


def test_eval_bridge_synthesis_runs_the_from_image_pipeline(tmp_path):
    """scripts/eval_bridge.py --synth scores what `cvt synthesize --from-image` makes: a tiled
    picture's lattice tiles the output (lattice "yes", two discs a cell); --no-lattice
    arranges freely."""
    import argparse
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
    import eval_bridge

    pic = _tiled_discs(tmp_path / "in.png")
    row, svg = eval_bridge.vector_row(pic, None, "felzenszwalb", None,
                                      eval_bridge.VectorizeParams(), "masks")
    args = argparse.Namespace(levels=1, iterations=1, seed=0, init="patch", w_a=1.0,
                              no_lattice=False)
    tiled = eval_bridge.synth_row(pic, svg, args)
    free = eval_bridge.synth_row(pic, svg, argparse.Namespace(**{**vars(args),
                                                                "no_lattice": True}))
    assert tiled["lattice"] == "yes" and free["lattice"] == "no"
    assert tiled["out_elements"] >= 4 * 16 * 2  # 2x: 8 x 8 cells of at least two discs
    assert tiled["swd"] < free["swd"]  # the tile continued is closer to the picture
    assert eval_bridge._mean(["yes", "no", "yes"]) == "2/3"


def _cells(path, side: int = 96, cells: int = 60) -> None:
    """A picture that its segments partition: Voronoi cells of random colours with light
    joints; the cells' boxes overlap their neighbours', as a wall's irregular stones do."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:side, 0:side]
    cell = cKDTree(rng.random((cells, 2)) * side).query(np.c_[xx.ravel(), yy.ravel()])[1]
    cell = cell.reshape(side, side)
    img = (rng.random((cells, 3)) * 0.5 + 0.3)[cell]
    joint = np.zeros((side, side), bool)
    joint[:, 1:] |= cell[:, 1:] != cell[:, :-1]
    joint[1:] |= cell[1:] != cell[:-1]
    img[joint] = 0.9
    Image.fromarray((img * 255).astype(np.uint8)).save(path)


@pytest.mark.slow
def test_from_image_of_touching_segments_fills_the_whole_canvas(tmp_path):
    """A picture's segments touch, so their boxes overlap; chained into composites they made
    one group of nearly all elements, and the density repair left a quarter of the 2x canvas
    empty. Arranged as single elements, every quarter holds its share."""
    from cvt.limits import SvgLimits

    _cells(tmp_path / "in.png")
    out, ex = tmp_path / "out.svg", tmp_path / "ex.svg"
    assert main(["synthesize", "--from-image", str(tmp_path / "in.png"), "-o", str(out),
                 "--exemplar-out", str(ex), "--segmenter", "felzenszwalb", "--scale", "2",
                 "--no-lattice", "--levels", "2", "--iterations", "3", "--quiet"]) == 0
    big = SvgLimits(max_elements=5000)
    exemplar = [e for e in parse_svg(ex.read_bytes(), limits=big).elements
                if e.node.get("data-background") != "1"]
    result = parse_svg(out.read_bytes(), limits=big)
    placed = [e for e in result.elements if e.node.get("data-background") != "1"]
    assert len(placed) > 3 * len(exemplar)
    centres = np.array([(e.bbox[:2] + e.bbox[2:]) / 2 for e in placed])
    half = result.viewbox[2] / 2
    for right in (False, True):
        for low in (False, True):
            quarter = ((centres[:, 0] >= half) == right) & ((centres[:, 1] >= half) == low)
            assert quarter.sum() > 0.15 * len(placed)
