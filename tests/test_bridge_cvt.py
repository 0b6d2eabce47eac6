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
