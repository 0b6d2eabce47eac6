"""Toroidal synthesis for --tileable (cvt/torus.py and its use in neighbourhoods, search,
assignment, existence and the tileable canvas)."""

from pathlib import Path

import numpy as np
import torch

from cvt.assignment import assign_positions
from cvt.boxes import box_iou
from cvt.neighborhood import DistanceParams, neighborhoods, pair_space
from cvt.pattern import PatternOptions, synthesize_pattern
from cvt.seam import seam_step
from cvt.search import Matches
from cvt.svg import load_svg
from cvt.synthesis import SynthesisConfig
from cvt.torus import Torus

EXEMPLARS = Path(__file__).resolve().parents[1] / "cvt" / "exemplars"
BOX = (0.0, 0.0, 100.0, 50.0)


def test_sample_by_the_right_edge_sees_neighbours_across_the_left_edge():
    pos = torch.tensor([[98.0, 25.0], [1.0, 25.0], [50.0, 25.0], [98.0, 49.0], [98.0, 1.0]])
    plain = neighborhoods(pos, 5.0, 4)
    assert (plain[0] == -1).all()  # nothing within 5 on the plane
    nbr = neighborhoods(pos, 5.0, 4, torus=Torus.of(BOX))
    assert nbr[0].tolist() == [1, -1, -1, -1]  # 3 units away across the seam
    assert nbr[1].tolist() == [0, -1, -1, -1]
    assert nbr[3].tolist() == [4, -1, -1, -1]  # and across the top / bottom seam
    assert (nbr[2] == -1).all()


def test_neighbourhood_offsets_wrap_in_the_distance():
    """The same neighbourhood, once inside the canvas and once across the seam, is at
    distance 0 from its input copy."""
    inp = torch.tensor([[10.0, 10.0], [13.0, 10.0]])
    out = torch.tensor([[99.0, 10.0], [2.0, 10.0]])  # offset +3 across x = 100
    t = Torus.of(BOX)
    nbr = neighborhoods(out, 5.0, 1, torus=t)
    in_nbr = neighborhoods(inp, 5.0, 1)
    sp = pair_space(out, nbr, inp, in_nbr, torch.zeros(2, 2), DistanceParams(1.0), t)
    from cvt.neighborhood import distance_batched

    d, matched = distance_batched(sp, torch.tensor([0]), torch.tensor([0]))
    assert float(d[0]) < 1e-9 and matched[0, 0] == 1


def test_assignment_keeps_a_consistent_layout_across_the_seam():
    pos = torch.tensor([[99.0, 10.0], [2.0, 10.0]], dtype=torch.float64)
    inp = torch.tensor([[10.0, 10.0], [13.0, 10.0]], dtype=torch.float64)
    m = Matches(torch.tensor([0, 1]), torch.tensor([[1], [0]]), torch.tensor([[1], [0]]),
                torch.zeros(2))
    new = assign_positions(pos, m, inp, torus=Torus.of(BOX))
    assert torch.allclose(new, pos, atol=1e-6)  # the votes agree: nothing moves
    pulled = assign_positions(pos, m, inp)  # on the plane they pull the samples together
    assert (pulled[0, 0] - pulled[1, 0]).abs() < 90


def test_gather_puts_a_cluster_across_the_seam_side_by_side():
    t = Torus.of(BOX)
    pos = torch.tensor([[99.0, 10.0], [1.5, 10.0], [250.0, 60.0]])
    g = t.gather(pos, torch.tensor([0, 0, 1]))
    assert torch.allclose(g[:2], torch.tensor([[99.0, 10.0], [101.5, 10.0]]))
    assert torch.allclose(g[2], torch.tensor([50.0, 10.0]))  # wrapped onto the canvas


def _tileable(ex, size, tileable=True):
    cfg = SynthesisConfig(levels=2, iterations=3, seed=3)
    return synthesize_pattern(ex, size, cfg, "full", PatternOptions(tileable=tileable))


def test_tileable_pattern_repeats_without_seam():
    ex = load_svg(EXEMPLARS / "stars_and_dots.svg")
    size = (ex.viewbox[2] * 1.5, ex.viewbox[3] * 1.5)
    pattern = _tileable(ex, size)
    assert "torus" in " ".join(pattern.notes)
    boxes = np.stack([e.bbox for e in ex.elements])
    mb = np.stack([boxes[e] + [dx, dy, dx, dy] for e, dx, dy in pattern.placements])
    x0, y0 = ex.viewbox[:2]
    w, h = size
    # every copy crossing an edge has its twin one period away
    for b in mb[(mb[:, 0] < x0) | (mb[:, 2] > x0 + w)]:
        shift = w if b[0] < x0 else -w
        assert np.abs(mb - (b + [shift, 0, shift, 0])).max(1).min() < 1e-6
    # no motif doubled across the seam: the tiled copies overlap as little as inside
    tiled = np.concatenate([mb + [i * w, j * h, i * w, j * h] for i in (0, 1) for j in (0, 1)])
    iou = box_iou(tiled, tiled)
    np.fill_diagonal(iou, 0)
    ex_iou = box_iou(boxes, boxes)
    np.fill_diagonal(ex_iou, 0)
    same = np.isclose(iou, 1.0)  # a copy and its own periodic twin drawn twice
    assert (iou[~same] <= ex_iou.max() + 0.15).all()


def test_seam_step_sees_a_cut_and_not_a_period():
    y, x = np.mgrid[0:64, 0:64]
    img = np.stack([(np.sin((x + y) / 64 * 2 * np.pi * 4) > 0)] * 3, -1).astype(np.float32)
    seam, near = seam_step(img)
    assert seam <= 1.1 * near
    seam_bad, near_bad = seam_step(img[:, :56])  # cut mid-period: a step all along the seam
    assert seam_bad > 1.5 * near_bad
