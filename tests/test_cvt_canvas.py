"""Canvas rules, density, companions and tileable output (cvt/canvas.py, companions.py,
tileable.py)."""

import numpy as np

from cvt.canvas import (
    drop_overlaps,
    keep_on_canvas,
    kind_rates,
    moved_boxes,
    overlap_limits,
    repair_density,
)
from cvt.companions import companion_kinds, drop_orphans
from cvt.tileable import wrap_around

BOXES = np.array([[0, 0, 4, 4], [10, 10, 12, 12], [0, 8, 3, 11.0]])  # big, small, fragment
CUT = np.array([False, False, True])
KINDS = np.array([0, 1, 2])


def test_off_canvas_and_interior_fragments_are_dropped():
    placed = [(0, 5, 5), (0, 500, 5), (1, -11, 0), (2, 20, 0), (2, 0, 0)]
    kept = keep_on_canvas(placed, BOXES, CUT, (0, 0, 40, 40))
    # (1, -11, 0) crosses the left border: kept; the fragment stays only on the border
    assert kept == [(0, 5, 5), (1, -11, 0), (2, 0, 0)]
    inside = keep_on_canvas(placed, BOXES, CUT, (0, 0, 40, 40),
                            lambda xy: np.linalg.norm(xy - 20, axis=1) < 5)
    assert inside == []  # no copy touches the disc in the middle


def test_density_repair_reaches_the_exemplar_rate_per_kind():
    rng = np.random.default_rng(0)
    boxes = np.array([[0, 0, 2, 2], [0, 0, 1, 1.0]])
    kinds = np.array([0, 1])
    rates = {0: 0.01, 1: 0.02}  # per unit area
    placed = repair_density([], boxes, kinds, rates, [[0], [1]], (0, 0, 50, 50), 2500, rng)
    counts = np.bincount([kinds[e] for e, _, _ in placed], minlength=2)
    assert abs(counts[0] - 25) <= 1 and abs(counts[1] - 50) <= 2
    mb = moved_boxes(placed, boxes)
    assert (mb[:, :2] >= -1).all() and (mb[:, 2:] <= 52).all()
    crowded = placed + [(1, 3.0, 3.0)] * 30  # a stack of surplus copies goes again
    thinned = repair_density(crowded, boxes, kinds, rates, [[0], [1]], (0, 0, 50, 50), 2500, rng)
    assert abs(sum(kinds[e] == 1 for e, _, _ in thinned) - 50) <= 3


def test_kind_rates_count_whole_elements_centred_on_the_canvas():
    rates = kind_rates(BOXES, KINDS, CUT, (0, 0, 20, 20))
    assert rates == {0: 1 / 400, 1: 1 / 400}


def test_overlaps_beyond_the_exemplar_are_dropped_pairs_within_it_kept():
    boxes = np.array([[0, 0, 10, 10], [2, 2, 6, 6], [30, 30, 40, 40.0]])  # heart, butterfly on it
    kinds = np.array([0, 1, 0])
    lim = overlap_limits(boxes, kinds, np.zeros(3, bool))
    placed = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 31, 31), (0, 100, 100), (1, 100, 100)]
    assert drop_overlaps(placed, boxes, kinds, lim) == [(0, 0, 0), (1, 0, 0), (2, 0, 0),
                                                        (0, 100, 100), (1, 100, 100)]


def test_companions_without_their_host_are_orphans():
    boxes = np.array([[0, 0, 10, 10], [2, 2, 6, 6], [20, 0, 30, 10], [22, 2, 26, 6],
                      [40, 0, 50, 10.0]])  # two hearts with a butterfly, one without
    kinds = np.array([0, 1, 0, 1, 0])
    pairs = companion_kinds(boxes, kinds, np.zeros(5, bool))
    assert pairs == {1: {0}}  # butterflies need a heart, hearts may be alone
    placed = [(0, 0, 0), (1, 0, 0), (1, 50, 50), (0, 80, 0)]
    assert drop_orphans(placed, boxes, kinds, pairs) == [(0, 0, 0), (1, 0, 0), (0, 80, 0)]


def test_wrap_around_draws_crossing_elements_on_both_sides_once_per_orbit():
    boxes = np.array([[0, 0, 4, 4.0]])
    placed = [(0, 37, 10), (0, 10, 10), (0, 10, 37), (0, 50, 50)]  # last one is off the torus
    out = wrap_around(placed, boxes, (0, 0, 40, 40))
    mb = moved_boxes(out, boxes)
    assert {tuple(b[:2]) for b in mb} == {(37, 10), (-3, 10), (10, 10), (10, 37), (10, -3)}
    # seamless: the canvas shifted by one period shows the same boxes inside it
    def seen(shift):
        b = mb + shift
        on = (b[:, 2] > 0) & (b[:, 0] < 40) & (b[:, 3] > 0) & (b[:, 1] < 40)
        return {tuple(np.round(x, 6)) for x in b[on] % 40}
    assert seen(np.array([40, 0, 40, 0])) | seen(0) == seen(0)


def test_flower_needs_both_leaf_kinds_and_its_leaves_go_with_it():
    # a flower (kind 0) with a leaf of kind 1 and one of kind 2, in the exemplar
    boxes = np.array([[0, 0, 10, 10], [8, 0, 14, 6], [-4, 4, 2, 10.0]])
    kinds = np.array([0, 1, 2])
    pairs = companion_kinds(boxes, kinds, np.zeros(3, bool))
    assert pairs == {0: {1, 2}, 1: {0}, 2: {0}}
    whole = [(0, 0, 0), (1, 0, 0), (2, 0, 0)]
    lacking = [(0, 50, 0), (1, 50, 0)]  # no kind-2 leaf: the flower goes, then its leaf
    assert drop_orphans(whole + lacking, boxes, kinds, pairs) == whole


def test_thinning_never_breaks_a_pair():
    boxes = np.array([[0, 0, 10, 10], [2, 2, 6, 6.0]])  # a heart with its butterfly
    kinds = np.array([0, 1])
    pairs = companion_kinds(boxes, kinds, np.zeros(2, bool))
    rates = {0: 2 / 2500, 1: 2 / 2500}
    # four hearts, each with its butterfly: hearts and butterflies are 2x too many
    placed = [(e, dx, 0.0) for dx in (0, 12, 24, 36) for e in (0, 1)]
    rng = np.random.default_rng(0)
    out = repair_density(placed, boxes, kinds, rates, [[0, 1]], (0, 0, 50, 50), 2500, rng,
                         companions=pairs)
    assert drop_orphans(out, boxes, kinds, pairs) == out  # nobody left alone


def test_pairs_settle_between_the_rates_of_their_kinds():
    """The border lets an exemplar show 10 hearts and 8 butterflies that sit on them: pairs
    go in and out whole and settle where neither kind is off by more than it must be."""
    boxes = np.array([[0, 0, 4, 4], [1, 1, 3, 3.0]])
    kinds = np.array([0, 1])
    pairs = companion_kinds(boxes, kinds, np.zeros(2, bool))
    rates = {0: 10 / 2500, 1: 8 / 2500}
    placed = [(e, dx, dy) for dx in range(2, 50, 10) for dy in (2, 20, 38) for e in (0, 1)]
    rng = np.random.default_rng(0)
    out = repair_density(placed, boxes, kinds, rates, [[0, 1]], (0, 0, 50, 50), 2500, rng,
                         companions=pairs)
    n = np.bincount([kinds[e] for e, _, _ in out], minlength=2)
    assert n[0] == n[1] == 9  # 15 pairs thinned to 9: -10 % and +12.5 %


def test_touches_columns_are_those_of_the_full_matrix():
    from cvt.companions import touches
    from cvt.torus import Torus

    rng = np.random.default_rng(3)
    lo = rng.uniform(0, 10, (120, 2))
    b = np.c_[lo, lo + rng.uniform(0.2, 2, (120, 2))]
    cols = np.array([0, 5, 7, 64, 119])
    for torus in (None, Torus.of((0, 0, 10, 10))):
        full = touches(b, torus=torus)
        assert full.any() and not full.diagonal().any()
        assert np.array_equal(touches(b, torus=torus, cols=cols), full[:, cols])
