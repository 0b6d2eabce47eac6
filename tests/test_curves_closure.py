"""close_ends (cvt.curves.closure): no stroke end left where the exemplar has none."""

import math

import numpy as np
import torch

from cvt.curves.closure import _bridged, bridge, close_ends
from cvt.curves.graph import StrokeStyle, components
from cvt.curves.sampling import stroke_graph
from cvt.curves.strokes import Stroke

STYLE = [StrokeStyle("#000000", 1.0)]
DELTA = 2.0


def _graph(polylines, closed=False):
    return stroke_graph([Stroke(np.asarray(p, float), closed, 0) for p in polylines], STYLE,
                        DELTA)


def _inner(g, margin=2 * DELTA):
    p = g.pos.numpy()
    return ((p > margin) & (p < 100 - margin)).all(1)


def _interior_ends(g):
    return int(((g.degree().numpy() == 1) & _inner(g)).sum())


def test_facing_ends_are_bridged_by_a_smooth_run_of_samples():
    out = _graph([[[0, 50], [40, 50]], [[100, 52], [56, 52]]])  # a 16-unit break
    fixed = close_ends(out, 0.0, _inner(out), DELTA)
    assert _interior_ends(fixed) == 0
    assert components(len(fixed), fixed.edges.numpy())[0] == 1
    new = fixed.pos.numpy()[len(out):]
    assert 6 <= len(new) <= 8  # ~ one sample per delta across the gap
    assert (new[:, 0] > 40).all() and (new[:, 0] < 56).all()
    step = np.linalg.norm(np.diff(new, axis=0), axis=1)
    assert step.max() < 1.5 * DELTA  # no long straight edge left for the Bézier to draw
    near = _graph([[[0, 50], [40, 50]], [[100, 50], [42, 50]]])  # a gap under one delta
    joined = close_ends(near, 0.0, _inner(near), DELTA)
    assert _interior_ends(joined) == 0 and len(joined) == len(near)  # one edge, no samples
    assert joined.style.dtype == torch.long


def test_the_bridge_leaves_along_the_end_tangent():
    out = _graph([[[0, 50], [40, 50]], [[60, 0], [60, 40]]])
    pos, nbr = out.pos.numpy(), out.adjacency()
    a = int(np.argmin(np.linalg.norm(pos - [40, 50], axis=1)))
    b = int(np.argmin(np.linalg.norm(pos - [60, 40], axis=1)))
    path = bridge(pos, nbr, a, b, DELTA)
    first = path[0] - pos[a]
    assert first[0] > 0 and abs(first[1]) < 0.5 * first[0]  # heads on to the right first
    last = pos[b] - path[-1]
    assert last[1] < 0 and abs(last[0]) < 0.5 * abs(last[1])  # and enters b upwards


def test_a_bridge_that_would_cross_a_stroke_is_not_drawn():
    out = _graph([[[0, 50], [40, 50]], [[100, 50], [60, 50]], [[50, 0], [50, 100]]])
    pos = out.pos.numpy()
    a = int(np.argmin(np.linalg.norm(pos - [40, 50], axis=1)))
    b = int(np.argmin(np.linalg.norm(pos - [60, 50], axis=1)))
    assert len(_bridged(out, [(a, b)], DELTA, 2)[0]) == len(out)
    clear = _graph([[[0, 50], [40, 50]], [[100, 50], [60, 50]]])
    assert len(_bridged(clear, [(a, b)], DELTA, 2)[0]) > len(clear)
    assert len(_bridged(clear, [(a, b)], DELTA, 1)[0]) == len(clear)  # over the budget


def test_an_open_ring_is_closed_again():
    t = np.linspace(0, 2 * math.pi * 0.93, 60)
    ring = np.stack([50 + 20 * np.cos(t), 50 + 20 * np.sin(t)], 1)  # a gap of ~8.8 units
    out = _graph([ring])
    fixed = close_ends(out, 0.0, _inner(out), DELTA)
    assert _interior_ends(fixed) == 0 and len(fixed) >= len(out)
    assert int((fixed.degree() == 2).sum()) == len(fixed)  # one closed loop


def test_a_loose_stroke_goes_unless_it_is_the_users():
    out = _graph([[[0, 20], [100, 20]], [[30, 60], [70, 60]]])  # a straight open piece
    fixed = close_ends(out, 0.0, _inner(out), DELTA)
    assert _interior_ends(fixed) == 0
    assert (fixed.pos.numpy()[:, 1] < 30).all()  # the line across stays, the piece went
    kept = close_ends(out, 0.0, _inner(out), DELTA, keep=len(out))
    assert len(kept) == len(out)


def test_exemplars_with_ends_keep_theirs():
    out = _graph([[[30, 60], [70, 60]]])
    assert close_ends(out, 0.05, _inner(out), DELTA) is out
    # scarce ends (under 1 per 100 samples): as many stay as the exemplar's rate allows
    lines = [[[0, y], [100, y]] for y in (4, 8, 12, 16, 20, 24)]  # many samples, no ends
    pieces = _graph([*lines, [[10, 50], [50, 50]], [[78, 88], [92, 88]]])
    n = int(_inner(pieces).sum())
    two = close_ends(pieces, 2.5 / n, _inner(pieces), DELTA)
    assert _interior_ends(two) == 2 and len(two) < len(pieces)
    assert (two.pos.numpy()[:, 1] < 70).all()  # the smaller loose piece went first


def test_a_stub_on_a_stroke_is_cut_back_to_its_junction():
    out = _graph([[[0, 20], [100, 20]], [[50, 20], [50, 50]]])  # a T whose leg ends in paper
    assert int((out.degree() >= 3).sum()) == 1 and _interior_ends(out) == 1
    fixed = close_ends(out, 0.0, _inner(out), DELTA)
    assert _interior_ends(fixed) == 0
    assert (fixed.pos.numpy()[:, 1] < 21).all()  # the leg went, the line stayed whole
    assert len(fixed) == len(out) - 15
