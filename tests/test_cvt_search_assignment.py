"""Search finds identity matches on a copy of the input; consistent votes move nothing."""

from pathlib import Path

import torch

from cvt.assignment import add_missing, assign_positions
from cvt.neighborhood import DistanceParams, neighborhoods, pair_space
from cvt.sampling import hierarchy, sample_exemplar
from cvt.search import Matches, NearestGrid, SearchParams, patchmatch
from cvt.shape_context import chi2_table
from cvt.svg import load_svg

EXEMPLARS = Path(__file__).resolve().parents[1] / "cvt" / "exemplars"
SHIFT = torch.tensor([250.0, 40.0])


def _copy_setup(name="stars", level=1):
    ex = load_svg(EXEMPLARS / f"{name}.svg")
    lv = hierarchy(ex.size)[level]
    inp = sample_exemplar(ex, lv.delta)
    nb = neighborhoods(inp.pos, lv.radius, 24)
    sp = pair_space(inp.pos + SHIFT, nb, inp.pos, nb, chi2_table(inp.feat, inp.feat),
                    DistanceParams(lv.delta))
    grid = NearestGrid(inp.pos, torch.arange(len(inp)), (0, 0, 200, 200), lv.delta / 3)
    return ex, lv, inp, nb, sp, grid


def test_search_on_a_copy_finds_the_identity():
    ex, lv, inp, nb, sp, grid = _copy_setup()
    gen = torch.Generator().manual_seed(0)
    start = torch.randint(0, len(inp), (len(inp),), generator=gen)
    m = patchmatch(sp, grid, start, SearchParams(passes=30), 100.0, gen)
    ident = torch.arange(len(inp))
    assert (m.center == ident).float().mean() > 0.97
    # wherever it is not the identity, it found another exact (zero-cost) neighborhood
    assert torch.allclose(m.cost[m.center != ident], torch.zeros(1), atol=1e-4)
    assert m.energy < 1e-4  # float32 round-off of the shifted copy


def test_search_never_gets_worse_than_its_start():
    ex, lv, inp, nb, sp, grid = _copy_setup()
    gen = torch.Generator().manual_seed(1)
    start = torch.randint(0, len(inp), (len(inp),), generator=gen)
    m0 = patchmatch(sp, grid, start, SearchParams(passes=0), 100.0, gen)
    m1 = patchmatch(sp, grid, start, SearchParams(passes=1), 100.0, gen)
    assert (m1.cost <= m0.cost + 1e-6).all()


def _identity_matches(inp, nb):
    return Matches(torch.arange(len(inp)), nb, nb.clone(), torch.zeros(len(inp)))


def test_consistent_votes_leave_positions_unchanged():
    ex, lv, inp, nb, sp, grid = _copy_setup()
    out = inp.pos + SHIFT
    new = assign_positions(out, _identity_matches(inp, nb), inp.pos)
    torch.testing.assert_close(new, out, atol=1e-4, rtol=0)


def test_votes_pull_a_displaced_sample_back():
    ex, lv, inp, nb, sp, grid = _copy_setup()
    out = inp.pos + SHIFT
    moved = out.clone()
    moved[5] += torch.tensor([2.0, -1.5])
    new = assign_positions(moved, _identity_matches(inp, nb), inp.pos)
    assert (new[5] - out[5]).norm() < 0.5 * (moved[5] - out[5]).norm()


def test_existence_adds_back_a_missing_sample():
    ex, lv, inp, nb, sp, grid = _copy_setup()
    gone = int(torch.argmax((nb >= 0).sum(1)))  # a sample with many neighbors
    keep = torch.tensor([k for k in range(len(inp)) if k != gone])
    out = inp.select(keep).with_(pos=inp.pos[keep] + SHIFT, source=keep)
    out_nb = neighborhoods(out.pos, lv.radius, 24)
    remap = torch.full((len(inp),), -1, dtype=torch.long)
    remap[keep] = torch.arange(len(keep))
    matched = torch.where(out_nb >= 0, keep[out_nb.clamp_min(0)], -1)  # identity matches
    m = Matches(keep, out_nb, matched, torch.zeros(len(keep)))
    new = add_missing(out, m, inp, nb, lv.delta, lv.radius, (0, 0, 1000, 1000))
    assert len(new) >= 1
    d = (new.pos - (inp.pos[gone] + SHIFT)).norm(dim=1)
    assert d.min() < 0.5 * lv.delta
    assert int(new.source[d.argmin()]) == gone
