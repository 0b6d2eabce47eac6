"""Neighborhood distance (eqs. 2-3): zero for identical neighborhoods, batched == per pair."""

import pytest
import torch

from cvt.neighborhood import (
    DistanceParams,
    cost_matrices,
    distance_batched,
    distance_reference,
    lower_bound,
    neighborhoods,
    pair_space,
    pruned_lower_bounds,
)
from cvt.shape_context import chi2_table, shape_contexts


def _random_set(n, seed, extent=60.0):
    g = torch.Generator().manual_seed(seed)
    pos = torch.rand(n, 2, generator=g, dtype=torch.float64) * extent
    cluster = torch.randint(0, n // 4, (n,), generator=g)
    return pos, shape_contexts(pos, cluster)


def test_neighborhoods_are_sorted_within_radius_and_padded():
    pos, _ = _random_set(80, 0)
    nb = neighborhoods(pos, 12.0, 10)
    assert nb.shape == (80, 10)
    for s in range(80):
        idx = nb[s][nb[s] >= 0]
        d = (pos[idx] - pos[s]).norm(dim=1)
        assert (d <= 12.0).all() and (d[1:] >= d[:-1]).all() and s not in idx.tolist()


def test_identical_neighborhoods_have_distance_zero():
    pos, feat = _random_set(60, 1)
    nb = neighborhoods(pos, 15.0, 16)
    p = DistanceParams(delta=4.0)
    sp = pair_space(pos + torch.tensor([300.0, -20.0], dtype=pos.dtype), nb, pos, nb,
                    chi2_table(feat, feat), p)
    d, matched = distance_batched(sp, torch.arange(60), torch.arange(60))
    assert torch.allclose(d, torch.zeros_like(d), atol=1e-9)
    assert torch.equal(matched, nb)  # every neighbor matched to itself


@pytest.mark.parametrize("seed, k_in", [(0, 16), (1, 16), (2, 16), (3, 5)])
def test_batched_equals_per_pair_scipy_reference(seed, k_in):
    out_pos, out_feat = _random_set(70, 10 + seed)
    in_pos, in_feat = _random_set(50, 20 + seed)
    p = DistanceParams(delta=5.0, w_f=10.0, c_out=4.0)
    # input neighborhoods reach farther (rectangular cost matrices), or hold fewer samples
    out_nb, in_nb = neighborhoods(out_pos, 14.0, 12), neighborhoods(in_pos, 17.0, k_in)
    sp = pair_space(out_pos, out_nb, in_pos, in_nb, chi2_table(out_feat, in_feat), p)
    g = torch.Generator().manual_seed(seed)
    o = torch.randint(0, 70, (200,), generator=g)
    i = torch.randint(0, 50, (200,), generator=g)
    d, _ = distance_batched(sp, o, i)
    center, cost, pad = cost_matrices(sp, o, i)
    lb = lower_bound(center, cost, pad)
    for b in range(200):
        on, inn = out_nb[o[b]], in_nb[i[b]]
        on, inn = on[on >= 0], inn[inn >= 0]
        ref = distance_reference(
            (out_pos[on] - out_pos[o[b]]).numpy(), (in_pos[inn] - in_pos[i[b]]).numpy(),
            out_feat[on].numpy(), in_feat[inn].numpy(), out_feat[o[b]].numpy(),
            in_feat[i[b]].numpy(), p)
        assert float(d[b]) == pytest.approx(ref, abs=1e-6)
        assert float(lb[b]) <= ref + 1e-6


def test_pruned_bounds_are_exact_below_the_bound_and_never_exceed_the_distance():
    out_pos, out_feat = _random_set(70, 3)
    in_pos, in_feat = _random_set(50, 4)
    p = DistanceParams(delta=5.0)
    sp = pair_space(out_pos, neighborhoods(out_pos, 14.0, 12), in_pos,
                    neighborhoods(in_pos, 14.0, 12), chi2_table(out_feat, in_feat), p)
    o, i = torch.arange(50), torch.arange(50).flip(0)
    full = lower_bound(*cost_matrices(sp, o, i))
    d, _ = distance_batched(sp, o, i)
    bound = full.median().expand(50)
    lb = pruned_lower_bounds(sp, o, i, bound)
    below = full < bound
    torch.testing.assert_close(lb[below], full[below])
    assert (lb[~below] >= bound[~below] - 1e-9).all()  # pruned: partial bound reached it
    assert (lb <= d + 1e-9).all()


def _slow_lower_bounds(sp, o, i):
    """Per pair, from scratch: the center term plus each output neighbour's cheapest clamped
    match (eq. 3), padded rows excluded (the reference of pruned_lower_bounds)."""
    out = []
    for a, b in zip(o.tolist(), i.tolist(), strict=True):
        on, inn = sp.out_nbr[a], sp.in_nbr[b]
        rel_o = sp.out_pos[on] - sp.out_pos[a]
        if sp.torus is not None:
            rel_o = torch.where((on >= 0)[:, None], sp.torus.diff(rel_o), rel_o)
        rel_i = sp.in_pos[inn] - sp.in_pos[b]
        cost = torch.cdist(rel_o / sp.p.delta, rel_i / sp.p.delta)
        cost = (cost + sp.table[on][:, inn]).clamp(max=sp.p.c_out)
        out.append(float(sp.table[a, b] + cost.min(1).values[on >= 0].sum()))
    return torch.tensor(out, dtype=sp.table.dtype)


@pytest.mark.parametrize("tileable", [False, True])
def test_pruned_bounds_equal_the_full_bound_below_the_bound(tileable):
    from cvt.torus import Torus

    out_pos, out_feat = _random_set(90, 5)
    in_pos, in_feat = _random_set(60, 6)
    torus = Torus.of((0, 0, 60, 60)) if tileable else None
    sp = pair_space(out_pos, neighborhoods(out_pos, 14.0, 12, torus=torus), in_pos,
                    neighborhoods(in_pos, 16.0, 14), chi2_table(out_feat, in_feat),
                    DistanceParams(delta=5.0), torus)
    g = torch.Generator().manual_seed(1)
    o, i = torch.randint(0, 90, (300,), generator=g), torch.randint(0, 60, (300,), generator=g)
    full = lower_bound(*cost_matrices(sp, o, i))
    torch.testing.assert_close(full, _slow_lower_bounds(sp, o, i))
    bound = full.quantile(0.7).expand(300).clone()
    bound[::7] = 0.0  # pairs whose center term alone reaches the bound
    lb = pruned_lower_bounds(sp, o, i, bound)
    below = full < bound
    assert below.sum() > 100 and torch.equal(lb[below], full[below])  # the same floats
    assert (lb[~below] >= bound[~below]).all()
