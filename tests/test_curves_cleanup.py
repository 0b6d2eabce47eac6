"""Clean-up after curve synthesis: stroke-end repair, fairing, the curvature statistic, and the
real stroke-art exemplars (data/real_curves) with their generator's helpers."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import torch

from cvt.curves.cleanup import (
    drop_fragments,
    excess_ends,
    join_ends,
    prune,
    repair_ends,
    spurs,
)
from cvt.curves.fairing import chain_neighbors, fair, fair_like, turning
from cvt.curves.graph import StrokeStyle
from cvt.curves.sampling import stroke_graph
from cvt.curves.stats import CURV_CENTERS, curvature_hist, soft_hist
from cvt.curves.strokes import Stroke, load_curves

ROOT = Path(__file__).resolve().parents[1]
STYLE = [StrokeStyle("#000000", 1.0)]
BOX = (0.0, 0.0, 100.0, 100.0)


def _graph(polylines, closed=False, delta=2.0):
    return stroke_graph([Stroke(np.asarray(p, float), closed, 0) for p in polylines], STYLE,
                        delta)


def _ends(g):
    return int((g.degree() == 1).sum())


def _line(y):  # a line across the whole box: its ends are on the border
    return [[0.0, y], [100.0, y]]


def test_facing_ends_are_joined_when_the_exemplar_has_none():
    ex = _graph([_line(30), _line(60)])
    broken = _graph([[[0, 50], [45, 50]], [[51, 50], [100, 50]]])  # a break in mid-canvas
    assert excess_ends(broken, ex, BOX, BOX, 2.0) == 2
    fixed = join_ends(broken, ex, BOX, BOX, 2.0)
    assert len(fixed.edges) == len(broken.edges) + 1 and excess_ends(fixed, ex, BOX, BOX, 2.0) == 0
    # ends that point away from each other stay apart
    apart = _graph([[[45, 50], [0, 50]], [[45, 53], [100, 53]]])
    assert len(join_ends(apart, ex, BOX, BOX, 2.0).edges) == len(apart.edges)


def test_ends_the_exemplar_has_are_kept():
    dashes = [[[x, y], [x + 10, y]] for x in range(10, 80, 20) for y in (20, 50, 80)]
    ex = _graph(dashes)
    out = _graph(dashes)
    assert excess_ends(out, ex, BOX, BOX, 2.0) <= 0
    assert len(repair_ends(out, ex, BOX, BOX, 2.0).edges) == len(out.edges)


def test_broken_off_fragments_are_dropped_not_the_strokes():
    ex = _graph([_line(30), _line(60)])
    out = _graph([_line(30), _line(60), [[40, 45], [48, 45]]])  # a stray piece
    fixed = drop_fragments(out, ex, BOX, BOX, 2.0)
    assert _ends(fixed) == 4 and len(fixed) < len(out)  # the two lines' border ends only
    kept = drop_fragments(out, ex, BOX, BOX, 2.0, keep=len(out))  # a user's strokes stay
    assert len(kept) == len(out)


def test_an_end_runs_into_the_stroke_ahead_where_the_exemplar_has_junctions():
    ex = _graph([_line(50), [[50, 0], [50, 100]]])  # a crossing: junctions
    out = _graph([_line(50), [[50, 0], [50, 45]]])  # stops 5 short of the line
    fixed = repair_ends(out, ex, BOX, BOX, 2.0)
    assert int((fixed.degree() >= 3).sum()) == 1 and excess_ends(fixed, ex, BOX, BOX, 2.0) <= 0


def _wobbly(rng, n=40):
    x = np.linspace(0, 100, n)
    return [np.c_[x, 50 + rng.normal(0, 0.6, n)]]


def test_fairing_straightens_a_wobbly_line_and_keeps_corners_and_ends():
    g = _graph(_wobbly(np.random.default_rng(0)), delta=2.5)
    mid, nb = chain_neighbors(g)
    before = float(turning(g.pos, mid, nb).mean())
    f = fair(g, 4, mu=0.0)
    assert float(turning(f.pos, mid, nb).mean()) < 0.5 * before
    ends = torch.nonzero(g.degree() == 1).flatten()
    assert torch.equal(f.pos[ends], g.pos[ends])
    square = _graph([[[20, 20], [80, 20], [80, 80], [20, 80]]], closed=True, delta=5.0)
    sharp = turning(square.pos, *chain_neighbors(square)) > math.radians(80)
    faired = fair(square, 4)
    assert int(sharp.sum()) == 4
    assert torch.allclose(faired.pos[chain_neighbors(square)[0][sharp]],
                          square.pos[chain_neighbors(square)[0][sharp]])
    kept = fair(g, 4, keep=len(g))  # a user's strokes do not move
    assert torch.equal(kept.pos, g.pos)


def test_taubin_fairing_keeps_a_circle_round():
    t = np.linspace(0, 2 * np.pi, 30, endpoint=False)
    g = _graph([np.c_[50 + 20 * np.cos(t), 50 + 20 * np.sin(t)]], closed=True, delta=4.0)
    r = (fair(g, 4).pos - 50).norm(dim=1)
    lap = (fair(g, 4, mu=0.0).pos - 50).norm(dim=1)
    assert abs(float(r.mean()) - 20) < 0.3 < abs(float(lap.mean()) - 20)


def test_fair_like_picks_no_smoothing_for_jagged_and_some_for_straight():
    rng = np.random.default_rng(1)
    x = np.linspace(0, 100, 60)
    jag = _graph([np.c_[x, 50 + 3 * (np.arange(60) % 2)]], delta=2.0)  # a zigzag exemplar
    out = _graph([np.c_[x, 50 + 3 * (np.arange(60) % 2) + rng.normal(0, 0.1, 60)]], delta=2.0)
    assert torch.equal(fair_like(out, jag, BOX, BOX, 2.0).pos, out.pos)
    straight = _graph([_line(50)], delta=2.5)
    wob = _graph(_wobbly(rng), delta=2.5)
    h0 = curvature_hist(wob, BOX, 2.5)
    h1 = curvature_hist(fair_like(wob, straight, BOX, BOX, 2.5), BOX, 2.5)
    assert h1[0] > h0[0]  # more mass at zero curvature, like the straight exemplar


def test_soft_histogram_splits_between_centres():
    h = soft_hist(np.array([0.05, 0.10, 9.0]), CURV_CENTERS)
    assert np.isclose(h.sum(), 1) and np.isclose(h[0], 1.5 / 3) and np.isclose(h[1], 0.5 / 3)
    assert np.isclose(h[-1], 1 / 3)  # beyond the last centre: the last bin
    # a value on a bin edge and one just past it give nearly the same histogram
    a, b = soft_hist(np.array([0.5]), CURV_CENTERS), soft_hist(np.array([0.49]), CURV_CENTERS)
    assert 0.5 * np.abs(a - b).sum() < 0.11


def _make_real():
    spec = importlib.util.spec_from_file_location("make_real_curves",
                                                  ROOT / "scripts" / "make_real_curves.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_real_stroke_art_is_shipped_with_sources():
    real = ROOT / "data" / "real_curves"
    names = sorted(p.stem for p in real.glob("*.svg"))
    assert len(names) >= 6
    sources = (real / "SOURCES.md").read_text()
    for n in names:
        assert f"`{n}.svg`" in sources
        assert len(load_curves(real / f"{n}.svg").strokes) > 5


def test_real_curve_helpers(tmp_path):
    mod = _make_real()
    pieces = mod.clip_polyline(np.array([[-10.0, 50], [50, 50], [50, 250]]), (0, 0, 100, 100))
    assert len(pieces) == 1 and pieces[0][0, 0] <= 1 and pieces[0][-1, 1] >= 99
    two = mod.clip_polyline(np.array([[10.0, 50], [150, 50], [150, 60], [10, 60]]),
                            (0, 0, 100, 100))
    assert len(two) == 2
    line = np.c_[np.linspace(0, 10, 50), np.zeros(50)]
    assert len(mod.simplify(line, 0.01)) == 2
    font = tmp_path / "f.jhf"  # space, then "!" as two pen strokes, with a wrapped record
    font.write_text("12345  1JZ\n12346  7MWRFRT RRYQZ\nRZ\n")
    glyphs = mod.read_jhf(font)
    assert glyphs[32] == (-8, 8, []) and len(glyphs[33][2]) == 2
    assert glyphs[33][2][0].tolist() == [[0, -12], [0, 2]] and len(glyphs[33][2][1]) == 3


def test_fair_like_keeps_the_corners_of_a_zigzag_hatch():
    """Straight runs at +-30 degrees, redrawn with a wobble: the corner-keeping strengths
    straighten the runs and leave the corners; the 60-degree ones smooth the corners too."""
    from cvt.curves.fairing import STRENGTHS
    from cvt.curves.stats import tv

    rng = np.random.default_rng(0)
    turn = math.radians(30)
    pts, p = [], np.array([0.0, 20.0])
    for k in range(8):  # a zigzag of 10-unit runs
        a = turn if k % 2 else -turn
        for _ in range(5):
            pts.append(p.copy())
            p = p + 2.0 * np.array([math.cos(a), math.sin(a)])
    zig = np.array(pts)
    ex = _graph([zig], delta=2.0)
    out = _graph([zig + rng.normal(0, 0.2, zig.shape)], delta=2.0)
    ref = curvature_hist(ex, BOX, 2.0)
    got = tv(curvature_hist(fair_like(out, ex, BOX, BOX, 2.0), BOX, 2.0), ref)
    old = min(tv(curvature_hist(fair(out, k, c, mu=mu), BOX, 2.0), ref)
              for k, mu, c in STRENGTHS if c == 60.0)
    assert got < old


def test_short_pad_to_pad_leads_stay_where_the_exemplar_has_pads():
    from cvt.curves.cleanup import prune

    def padded(polylines):
        g = _graph(polylines)
        deg1 = torch.nonzero(g.degree() == 1).flatten()
        pads = g.select(deg1).with_(kind=torch.zeros(len(deg1), dtype=torch.long),
                                    edges=torch.zeros(0, 2, dtype=torch.long))
        return g.cat(pads)

    ex = padded([[[20, 20], [60, 20]], [[20, 60], [20, 90]]])  # 20+ samples each, pads at ends
    lead = [[50, 50], [58, 50]]  # 5 samples: smaller than the exemplar's pieces
    assert len(prune(padded([lead]), ex, BOX, BOX, 2.0)) == len(padded([lead]))
    assert int((prune(_graph([lead]), ex, BOX, BOX, 2.0).kind < 0).sum()) == 0  # bare: dust


def test_open_pieces_smaller_than_the_exemplars_open_ones_go_closed_dots_stay():
    dot = [[50 + 3 * math.cos(t), 20 + 3 * math.sin(t)] for t in np.linspace(0, 6.0, 12)]
    ex = stroke_graph([Stroke(np.array(dot), True, 0),
                       Stroke(np.array([[10.0, 60], [60, 60]]), False, 0)], STYLE, 2.0)
    tick = [[20.0, 80], [44, 80]]  # open, 13 samples: more than the dot's 9, under the line's 26
    out = stroke_graph([Stroke(np.array(dot), True, 0), Stroke(np.array(tick), False, 0),
                        Stroke(np.array([[10.0, 40], [60, 40]]), False, 0)], STYLE, 2.0)
    kept = prune(out, ex, BOX, BOX, 2.0)
    assert _ends(kept) == 2 and len(kept) == len(out) - 13  # the tick went, the dot stayed
    assert len(prune(out, ex, BOX, BOX, 2.0, keep=len(out))) == len(out)


def test_spurs_far_longer_than_the_exemplars_ticks_are_stubs():
    # the exemplar's only spurs are 1-sample ticks on a line (a letter's serifs)
    ticks = [[[x, 50.0], [x, 52.0]] for x in (20.0, 40.0, 60.0)]
    ex = _graph([_line(50), *ticks])
    spur_lens = sorted(len(c) for c in spurs(ex, BOX, 4.0))
    assert spur_lens == [1, 1, 1]
    long_tail = [[50.0, 50.0], [50.0, 70.0]]  # a 10-sample stroke hanging off the line
    out = _graph([_line(50), *ticks, long_tail])
    kept = prune(out, ex, BOX, BOX, 2.0)
    assert _ends(kept) == _ends(out) - 1 and len(kept) == len(out) - 10
    # where the exemplar's spurs are long themselves, the same tail stays
    ex_long = _graph([_line(50), ticks[0], [[30.0, 50.0], [30.0, 74.0]]])
    assert len(prune(out, ex_long, BOX, BOX, 2.0)) == len(out)


def test_smallest_open_piece_of_a_dashed_exemplar():
    from cvt.curves.cleanup import smallest_open

    dashes = _graph([[[x, 50.0], [x + 4, 50.0]] for x in (20.0, 40.0, 60.0)]  # 3 samples each
                    + [[[20.0, 70.0], [60.0, 70.0]]])
    assert smallest_open(dashes, BOX, 2.0) == 3  # the synthesis keeps fragments that long
    ring = [[50 + 10 * math.cos(t), 30 + 10 * math.sin(t)] for t in np.linspace(0, 6.2, 30)]
    closed = stroke_graph([Stroke(np.array(ring), True, 0)], STYLE, 2.0)
    assert smallest_open(closed, BOX, 2.0) == 0  # no open piece: the default stays
