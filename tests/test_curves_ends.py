"""Stroke ends the matched neighborhoods do not back (cvt.curves.ends), the init by boundary
similarity (cvt.curves.init) and the before / after stages of the eval (cvt.curves.baselines)."""

import numpy as np
import torch

from cvt.curves.ends import (
    capped_ends,
    close_breaks,
    drop_broken,
    end_evidence,
    unwanted_ends,
)
from cvt.curves.graph import StrokeStyle
from cvt.curves.init import patch_init
from cvt.curves.sampling import stroke_graph
from cvt.curves.strokes import Stroke

STYLE = [StrokeStyle("#000000", 1.0)]


def _graph(polylines, delta=2.0):
    return stroke_graph([Stroke(np.asarray(p, float), False, 0) for p in polylines], STYLE,
                        delta)


def _want(g, value):
    return np.full(len(g), float(value))


def test_a_break_between_two_stroke_styles_is_not_closed():
    two = [StrokeStyle("#000000", 1.0), StrokeStyle("#00aa00", 6.0)]
    g = stroke_graph([Stroke(np.array([[0.0, 50], [45, 50]]), False, 0),
                      Stroke(np.array([[51.0, 50], [100, 50]]), False, 1)], two, 2.0)
    assert len(close_breaks(g, _want(g, 2.0), reach=8.0).edges) == len(g.edges)
    same = g.with_(style=torch.zeros(len(g), dtype=torch.long))
    assert len(close_breaks(same, _want(g, 2.0), reach=8.0).edges) == len(g.edges) + 1


def test_a_break_inside_a_stroke_is_closed_only_where_the_matches_say_stroke():
    g = _graph([[[0, 50], [45, 50]], [[51, 50], [100, 50]]])  # a 6-unit break
    fixed = close_breaks(g, _want(g, 2.0), reach=8.0)
    assert len(fixed.edges) == len(g.edges) + 1 and len(unwanted_ends(fixed, _want(g, 2))) == 2
    # the exemplar has ends there (expected degree 1): the break stays
    assert len(close_breaks(g, _want(g, 1.0), reach=8.0).edges) == len(g.edges)
    # too far apart for the reach
    assert len(close_breaks(g, _want(g, 2.0), reach=4.0).edges) == len(g.edges)


def test_ends_pointing_away_are_not_joined_tips_side_by_side_are():
    g = _graph([[[45, 50], [100, 50]], [[51, 56], [0, 56]]])  # 8.5 apart, pointing away
    assert len(close_breaks(g, _want(g, 2.0), reach=10.0).edges) == len(g.edges)
    tip = _graph([[[0, 50], [45, 50]], [[0, 53], [45, 53]]])  # a peninsula without its tip
    fixed = close_breaks(tip, _want(tip, 2.0), reach=8.0)
    assert len(fixed.edges) == len(tip.edges) + 2  # both tips (x = 0 and 45)
    assert len(close_breaks(tip, _want(tip, 2.0), reach=4.0).edges) == len(tip.edges)


def test_an_open_loop_is_closed_again():
    t = np.linspace(0, 2 * np.pi * 0.9, 60)  # a circle with a 10 % gap
    g = _graph([np.c_[50 + 30 * np.cos(t), 50 + 30 * np.sin(t)]])
    fixed = close_breaks(g, _want(g, 2.0), reach=10.0)  # gap 19: only the loop rule (2 reach)
    assert int((fixed.degree() == 1).sum()) == 0 and len(fixed.edges) == len(fixed)
    assert len(close_breaks(g, _want(g, 2.0), reach=4.0).edges) == len(g.edges)


def test_an_end_runs_on_into_an_expected_junction_only():
    g = _graph([[[0, 50], [100, 50]], [[50, 0], [50, 45]]])  # stops 5 short of the line
    want = _want(g, 2.0)
    assert len(close_breaks(g, want, reach=8.0).edges) == len(g.edges)  # no junction expected
    near = (g.pos - torch.tensor([50.0, 50.0]).double()).norm(dim=1).numpy() < 1.5
    want[near] = 3.0
    fixed = close_breaks(g, want, reach=8.0)
    assert int((fixed.degree() >= 3).sum()) == 1


def test_broken_pieces_and_stubs_go_real_ends_stay():
    line = [[0, 50], [100, 50]]
    g = _graph([line, [[40, 30], [46, 30]], [[70, 50], [70, 56]]])  # a speck and a stub
    want = _want(g, 2.0)
    out = drop_broken(g, want, longest=6)
    assert len(out) == len(g) - 4 - 3 and int((out.degree() >= 3).sum()) == 0
    assert len(drop_broken(g, _want(g, 1.0), longest=6)) == len(g)  # ends the exemplar has
    assert len(drop_broken(g, want, longest=6, keep=len(g))) == len(g)  # a user's strokes


def test_a_piece_cut_by_the_border_that_runs_out_inside_goes():
    g = _graph([[[0, 50], [24, 50]]])  # 13 samples from the border
    rim = (g.pos[:, 0] < 3).numpy()
    assert len(drop_broken(g, _want(g, 2.0), longest=6)) == len(g)
    assert len(drop_broken(g, _want(g, 2.0), longest=6, rim=rim)) == 0


def test_init_patches_continue_their_left_neighbour():
    # horizontal lines 10 apart, phase-shifted copies only fit one offset
    ys = np.arange(3, 200, 10.0)
    inp = _graph([[[0, y], [200, y]] for y in ys])
    box = (0.0, 0.0, 200.0, 200.0)

    def misfit(cands, seed=1):
        out = patch_init(inp, box, (0, 0, 120, 40), 40.0, lambda p: torch.ones(len(p), dtype=bool),
                         torch.Generator().manual_seed(seed), cands)
        y = out.pos[:, 1].numpy()
        return float(np.abs((y - y[0] + 5) % 10 - 5).max())  # off the first patch's lines

    chosen = np.mean([misfit(16, seed) for seed in range(6)])
    assert chosen < 1.0 and np.mean([misfit(1, seed) for seed in range(6)]) > 2.5 * chosen


def test_an_end_matched_to_an_input_end_is_wanted():
    want = np.array([2.0, 1.8, 2.0])
    capped = end_evidence(want, np.array([2, 1, 3]))
    assert capped.tolist() == [2.0, 1.0, 2.0]


def test_an_end_matched_to_a_padded_input_end_needs_its_pad():
    """A circuit's input ends carry a pad (a discrete element): an output end matched to one
    but without a pad near it is not backed (expected degree raised to a stroke's)."""
    g = _graph([[[10, 50], [40, 50]]])
    pad = g.select(torch.tensor([0])).with_(kind=torch.tensor([0]))  # an element at (10, 50)
    padded = g.cat(pad)
    capped = capped_ends(padded, 3.0)
    assert capped[:len(g)].sum() == 1 and not capped[len(g):].any()  # one end, not the far one
    assert not capped_ends(g, 3.0).any()  # no elements: nothing capped
    want = np.array([1.4, 1.4, 2.0])
    centers_are_ends = np.array([1, 1, 1])
    bare = np.array([True, False, False])
    got = end_evidence(want, centers_are_ends, bare)
    assert got[0] >= 1.5 and got[1] == 1.0  # the bare one unwanted, the padded one backed
    assert (end_evidence(want, centers_are_ends) == 1.0).all()


def test_ends_cut_by_the_exemplar_canvas_back_no_output_end():
    from cvt.curves.synthesis import run_on_degree

    g = _graph([[[0, 50], [50, 50]]])  # starts on the canvas border, ends inside
    deg = run_on_degree(g, (0.0, 0.0, 100.0, 100.0), 2.0)
    x = g.pos[:, 0]
    assert int(deg[x.argmin()]) == 2 and int(deg[x.argmax()]) == 1
    assert int(g.degree()[x.argmin()]) == 1  # the graph itself is unchanged


def test_ends_on_the_domain_rim_are_not_joined():
    g = _graph([[[0, 50], [45, 50]], [[51, 50], [100, 50]]])  # a 6-unit break
    rim = np.zeros(len(g), dtype=bool)
    x = g.pos[:, 0].numpy()
    rim[(x > 40) & (x < 56)] = True  # the border runs through the break
    assert len(close_breaks(g, _want(g, 2.0), reach=8.0, rim=rim).edges) == len(g.edges)
    assert len(close_breaks(g, _want(g, 2.0), reach=8.0).edges) == len(g.edges) + 1


def test_ends_side_by_side_stay_apart_where_the_exemplar_has_them():
    from cvt.curves.ends import SIDE_BY_SIDE, side_by_side

    bundle = _graph([[[20, y], [60, y]] for y in (40, 43, 46, 49)])  # parallel hatch strokes
    assert side_by_side(bundle, bundle.degree().numpy(), 4.0) > SIDE_BY_SIDE
    apart = _graph([[[20, 20], [60, 20]], [[20, 80], [60, 80]]])
    assert side_by_side(apart, apart.degree().numpy(), 4.0) == 0.0
    tip = _graph([[[20, 50], [60, 50]], [[20, 53], [60, 53]]])  # a U-turn that lost its tip
    want = _want(tip, 2.0)
    assert len(close_breaks(tip, want, reach=8.0).edges) == len(tip.edges) + 2
    assert len(close_breaks(tip, want, reach=8.0, side=False).edges) == len(tip.edges)


def test_facing_ends_stay_apart_where_the_exemplar_is_dashed():
    from cvt.curves.ends import paired_share
    from cvt.curves.synthesis import CurveConfig

    dashes = _graph([[[x, y], [x + 10, y]] for x in (10, 26, 42, 58) for y in (30, 60)])
    share = paired_share(dashes, dashes.degree().numpy(), 8.0, 0.3)
    assert share >= CurveConfig().facing_share  # the gaps of dashed lines: a feature
    apart = _graph([[[10, 20], [40, 20]], [[10, 80], [40, 80]]])
    assert paired_share(apart, apart.degree().numpy(), 8.0, 0.3) == 0.0
    g = _graph([[[0, 50], [45, 50]], [[51, 50], [100, 50]]])  # a 6-unit break
    assert len(close_breaks(g, _want(g, 2.0), reach=8.0).edges) == len(g.edges) + 1
    assert len(close_breaks(g, _want(g, 2.0), reach=8.0, ahead=False).edges) == len(g.edges)
