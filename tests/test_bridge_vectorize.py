"""Segments -> SVG (neuraltex.vectorize) on images with known discs, and `neuraltex vectorize`."""

import numpy as np
import pytest
import torch
from PIL import Image

from cvt.raster import render_svg
from cvt.svg import parse_svg
from neuraltex.cli import main
from neuraltex.segments import Segments, drop_background, from_labels, from_weights
from neuraltex.vectorize import VectorizeParams, fit_fill, simplify, to_svg, vectorize

DISCS = [  # x, y, radius, colour
    (14, 14, 7, (0.9, 0.1, 0.1)), (44, 16, 9, (0.1, 0.7, 0.2)), (20, 46, 8, (0.2, 0.3, 0.9)),
    (48, 46, 6, (0.95, 0.85, 0.1)), (32, 31, 4, (0.8, 0.2, 0.8)),
]
BACKGROUND = (0.5, 0.5, 0.5)


def disc_image(size: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 3) image and (H, W) labels (0 background, i + 1 disc i)."""
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    img = np.empty((size, size, 3))
    img[:] = BACKGROUND
    labels = np.zeros((size, size), np.int64)
    for i, (x, y, r, c) in enumerate(DISCS):
        inside = (xx - x) ** 2 + (yy - y) ** 2 <= r * r
        img[inside] = c
        labels[inside] = i + 1
    return img, labels


def _check_discs(svg_text: str, expect_extra: int = 0) -> None:
    ex = parse_svg(svg_text.encode())  # the project's own reader
    groups = [e for e in ex.elements if e.node.get("data-background") != "1"]
    assert abs(len(groups) - len(DISCS)) <= expect_extra
    for x, y, r, _ in DISCS:
        hits = [g for g in groups if np.allclose((g.bbox[:2] + g.bbox[2:]) / 2, (x, y), atol=1.0)]
        assert len(hits) == 1, (x, y)
        assert hits[0].bbox[2] - hits[0].bbox[0] == pytest.approx(2 * r, abs=2.5)  # + seam, spline


def test_discs_one_element_each_with_colour_and_position():
    img, labels = disc_image()
    seg = drop_background(from_labels(labels, img))
    assert seg.count == len(DISCS) + 1 and (seg.labels < 0).sum() == (labels == 0).sum()
    vec = vectorize(img, seg)
    assert len(vec.elements) == len(DISCS)
    for e in vec.elements:
        x, y, _, c = DISCS[int(seg.index[e.segment]) - 1]
        assert e.fill.gradient is None and np.allclose(e.fill.colour, c, atol=1e-6)
        pts = np.concatenate(e.rings)
        assert np.allclose(pts.mean(0), (x, y), atol=1.0)
    assert np.allclose(vec.background[0][4], BACKGROUND)
    text = to_svg(vec, seg)
    _check_discs(text)
    out = render_svg(text)  # rasterized at the input size, close to the input
    assert out.shape == img.shape and np.abs(out - img).mean() < 0.03


def test_discs_through_felzenszwalb():
    from neuraltex.segments import segment_image

    img, _ = disc_image()
    seg, textons = segment_image(torch.from_numpy(img).permute(2, 0, 1).float(), "felzenszwalb")
    assert textons is None
    vec = vectorize(img, seg)
    ex = parse_svg(to_svg(vec, seg).encode())
    assert len(ex.elements) == len(vec.elements)  # the background group is split off
    assert len(ex.background) == 1
    # Felzenszwalb's smoothing adds thin rims around the discs; each disc is still one element
    for x, y, _, c in DISCS:
        assert any(np.allclose(e.fill.colour, c, atol=0.05)
                   and np.allclose(np.concatenate(e.rings).mean(0), (x, y), atol=1.5)
                   for e in vec.elements)


def test_holes_are_kept_and_soft_margins_work():
    yy, xx = np.mgrid[0:40, 0:40] + 0.5
    d = np.hypot(xx - 20, yy - 20)
    ring = (d < 14) & (d > 6)
    labels, margin = from_weights(torch.from_numpy(np.stack([~ring, ring]).astype(np.float32)))
    assert (labels == ring).all() and np.allclose(margin, 1)
    img = np.where(ring[..., None], 1.0, 0.0) * np.ones(3)
    seg = Segments(labels, margin, np.array([0, 1]), np.ones(2), np.eye(2), np.arange(2))
    vec = vectorize(img, drop_background(seg, 0.1))
    assert len(vec.elements) == 1 and len(vec.elements[0].rings) == 2  # outer ring + hole
    out = render_svg(to_svg(vec, seg, seam=0))
    assert out[20, 20].max() < 0.1 and out[20, 30].min() > 0.9


def test_gradient_fill_only_when_it_helps():
    xy = np.stack(np.meshgrid(np.arange(20.0), np.arange(10.0)), -1).reshape(-1, 2)
    ramp = np.repeat(xy[:, :1] / 20, 3, 1)  # brightness grows with x
    fill = fit_fill(xy, ramp, VectorizeParams())
    p0, p1, c0, c1 = fill.gradient
    assert abs(p1[0] - p0[0]) > 5 * abs(p1[1] - p0[1])  # along x
    assert (c1 - c0).mean() * np.sign(p1[0] - p0[0]) > 0.5
    noise = np.random.default_rng(0).random((len(xy), 3))
    assert fit_fill(xy, noise, VectorizeParams()).gradient is None
    assert fit_fill(xy, ramp, VectorizeParams(gradient=False)).gradient is None


def test_simplify_keeps_corners_drops_collinear():
    side = np.arange(10.0)
    zero, ten = 0 * side, 10 + 0 * side
    square = np.concatenate([np.stack(xy, 1) for xy in
                             ((side, zero), (ten, side), (10 - side, ten), (zero, 10 - side))])
    assert len(simplify(square, 0.5)) == 4


@pytest.mark.parametrize("extra", [[], ["--source", "splat", "--background", "grid"],
                                   ["--mode", "ellipse"]])
def test_cli_model_path(tmp_path, tiny_checkpoint, extra):
    img, _ = disc_image(32)
    Image.fromarray((img * 255).astype(np.uint8)).save(tmp_path / "in.png")
    out = tmp_path / "out.svg"
    assert main(["vectorize", str(tmp_path / "in.png"), "-o", str(out),
                 "--checkpoint", tiny_checkpoint, *extra]) == 0
    ex = parse_svg(out.read_bytes())
    assert len(ex.background + ex.elements) > 1  # canvas-covering textons count as background
    for e in ex.background + ex.elements:
        if e.node.get("data-background") != "1":
            assert e.node.get("id").startswith("texton-")
            assert e.node.get("data-kind").startswith("k") and e.node.get("data-existence")
    assert render_svg(out.read_text()).shape == (32, 32, 3)
    if "ellipse" in extra:
        assert "<ellipse " in out.read_text() and "<path " not in out.read_text()


def test_ellipse_mode_places_the_gaussian():
    from neuraltex.vectorize import ellipses

    img, labels = disc_image()
    seg = from_labels(labels, img)
    mu = np.zeros((seg.count, 2))
    cov = np.tile(np.eye(2) * 1e-3, (seg.count, 1, 1))
    x, y, r, c = DISCS[1]
    mu[2], cov[2] = np.array([x, y]) / 64, np.diag([(r / 64) ** 2, (r / 2 / 64) ** 2])
    vec = ellipses(img, seg, mu, cov)
    e = next(e for e in vec.elements if e.segment == 2)
    assert np.allclose(e.ellipse[:4], (x, y, r, r / 2)) and np.allclose(e.fill.colour, c)
    parsed = parse_svg(to_svg(vec, seg).encode()).elements
    node = next(n for n in parsed if n.node.get("id") == "texton-2")  # label 2 = DISCS[1]
    assert np.allclose(node.bbox, (x - r, y - r / 2, x + r, y + r / 2), atol=0.05)


def test_cli_felzenszwalb_and_bad_input(tmp_path, capsys):
    img, _ = disc_image()
    Image.fromarray((img * 255).astype(np.uint8)).save(tmp_path / "in.png")
    out = tmp_path / "out.svg"
    assert main(["vectorize", str(tmp_path / "in.png"), "-o", str(out),
                 "--segmenter", "felzenszwalb"]) == 0
    assert len(parse_svg(out.read_bytes()).elements) > len(DISCS)
    (tmp_path / "bad.png").write_bytes(b"not an image")
    assert main(["vectorize", str(tmp_path / "bad.png"), "-o", str(out),
                 "--segmenter", "felzenszwalb"]) == 2
    assert main(["vectorize", str(tmp_path / "in.png"), "-o", str(tmp_path / "x.png"),
                 "--segmenter", "felzenszwalb"]) == 2
    assert main(["vectorize", str(tmp_path / "in.png"), "-o", str(out), "--mode", "ellipse",
                 "--segmenter", "felzenszwalb"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(line.startswith("neuraltex: error:") for line in err)


def test_mask_labels_in_chunks_equal_the_whole_argmax():
    """from_textons' labels from masks taken a chunk at a time (memory O(chunk x H x W) for
    the hundreds of textons of a tiled encoding) equal the argmax of all masks upsampled and
    normalized at once, margins included (ties, all-zero pixels, aside)."""
    import torch.nn.functional as F

    from neuraltex.segments import mask_argmax

    torch.manual_seed(0)
    for k in (1, 2, 5, 150):
        masks = torch.rand(k, 9, 7).softmax(0) * (torch.rand(1, 9, 7) > 0.2)
        up = F.interpolate(masks[None], size=(20, 15), mode="bilinear", align_corners=False)[0]
        labels, margin = from_weights(up / up.sum(0, keepdim=True).clamp_min(1e-8))
        got, got_margin = mask_argmax(masks, (20, 15), chunk=4)
        assert np.allclose(got_margin, margin, atol=1e-6)
        assert np.array_equal(got[margin > 0], labels[margin > 0])


def test_a_joint_network_spanning_the_picture_is_the_backdrop():
    """The mortar of a wall covers a fifth of it and touches every side: the backdrop, not an
    element; a large element that does not reach every side stays."""
    img = np.zeros((50, 50, 3))
    labels = np.zeros((50, 50), np.int64)  # 0: the joints, 1 px wide
    for i, (r, c) in enumerate(np.ndindex(5, 5)):
        labels[1 + 10 * r: 10 + 10 * r, 1 + 10 * c: 10 + 10 * c] = i + 1
    assert 0.1 < (labels == 0).mean() < 0.25
    seg = drop_background(from_labels(labels, img))
    assert (seg.labels < 0).sum() == (labels == 0).sum()
    blob = np.where(np.arange(50)[None, :] < 40, 1, 2) * np.ones((50, 1), np.int64)
    blob[45:, :] = 3  # the largest segment misses the bottom side
    assert (drop_background(from_labels(blob, img)).labels >= 0).all()
