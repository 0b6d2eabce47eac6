"""Search step: PatchMatch over samples (seed 001 sec. 4.3.3, seed 000 sec. 6.3).

For every output sample find the input sample whose neighborhood is nearest by seed 000 eq. 2. The
field starts random (plus any known source sample), then alternates propagation over the kNN
graph of output samples and random search in exponentially shrinking windows. All samples are
updated in parallel (Jacobi style) so one pass is a handful of batched tensor ops.

Every candidate first gets a cheap lower bound of seed 000 eq. 2 (each output neighbor takes its
best input neighbor); only a candidate whose bound beats the current exact distance is solved
exactly with the Hungarian method, so the field never gets worse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch

from cvt.neighborhood import PairSpace, distance_batched, pruned_lower_bounds
from cvt.torus import offsets


@dataclass
class Matches:
    """The nearest-neighbor field mu_s and the per-neighborhood matchings m_s of one step.

    Kept per iteration for the clustering step (link confidences from matched neighborhood
    pairs, seed 000 eq. 10-11) and depth order (eq. 8).
    """

    center: torch.Tensor  # (N,) input sample matched to each output center, mu_s
    out_nbr: torch.Tensor  # (N, K) output neighborhoods used
    matched: torch.Tensor  # (N, K) input sample matched to each output neighbor, -1 outlier
    cost: torch.Tensor  # (N,) seed 000 eq. 2 distance of each output neighborhood to its match

    @property
    def energy(self) -> float:
        """Seed 000 eq. 4 averaged over output samples."""
        return float(self.cost.mean()) if self.cost.numel() else 0.0


@dataclass(frozen=True)
class SearchParams:
    passes: int = 2  # PatchMatch passes per search step (5 on the first step of a level)
    n_prop: int = 6  # kNN neighbors used for propagation
    n_random: int = 2  # uniformly random input centers per pass (reach isolated elements)
    min_window: float = 1.0  # in units of delta; random search windows halve down to this


class NearestGrid:
    """Approximate nearest-sample lookup: a grid of cells (side h) over the input box, each
    holding the sample nearest to its center. Queries outside the box use the border cells.
    Error <= h / sqrt(2), plenty for PatchMatch candidates."""

    def __init__(self, pos: torch.Tensor, ids: torch.Tensor, box, h: float):
        x0, y0, x1, y1 = box
        self.origin = pos.new_tensor([x0, y0])
        self.h = h
        self.nx, self.ny = max(1, math.ceil((x1 - x0) / h)), max(1, math.ceil((y1 - y0) / h))
        gx = x0 + (torch.arange(self.nx, dtype=pos.dtype) + 0.5) * h
        gy = y0 + (torch.arange(self.ny, dtype=pos.dtype) + 0.5) * h
        centers = torch.stack(torch.meshgrid(gx, gy, indexing="ij"), -1).reshape(-1, 2)
        sub = pos[ids]
        near = torch.cat([torch.cdist(c, sub).argmin(1) for c in centers.split(4096)])
        self.cell = ids[near]  # (nx * ny,) sample id per cell, x-major
        self.ids = ids

    def __call__(self, q: torch.Tensor) -> torch.Tensor:
        """Shape: (Q, 2) -> (Q,) sample ids."""
        ij = torch.floor((q - self.origin) / self.h).long()
        i = ij[:, 0].clamp(0, self.nx - 1)
        j = ij[:, 1].clamp(0, self.ny - 1)
        return self.cell[i * self.ny + j]


def _candidates(field, out_pos, out_nbr, in_pos, grid, window0, params, delta, gen,
                torus=None):
    """Propagated and random-search candidate input centers. Shape: -> (N, C) long."""
    n = field.shape[0]
    cands = []
    k = min(params.n_prop, out_nbr.shape[1])
    if k > 0:
        t = out_nbr[:, :k]  # (N, k) neighbors whose match we borrow
        t0 = t.clamp_min(0)
        target = in_pos[field[t0]] + offsets(out_pos[:, None] - out_pos[t0], torus)  # (N, k, 2)
        near = grid(target.reshape(-1, 2)).view(n, k)
        cands.append(torch.where(t >= 0, near, field[:, None]))
    if params.n_random > 0:
        pick = torch.randint(len(grid.ids), (n, params.n_random), generator=gen)
        cands.append(grid.ids[pick])
    w = window0
    while w >= params.min_window * delta:
        off = (torch.rand(n, 2, generator=gen, dtype=in_pos.dtype) * 2 - 1) * w
        cands.append(grid(in_pos[field] + off)[:, None])
        w /= 2
    return torch.cat(cands, 1)


def _lower_bounds(sp: PairSpace, o, i, bound, chunk: int = 4096):
    """Lower bounds of seed 000 eq. 2 in chunks (bounded memory).
    Shape: o, i, bound (B,) -> (B,)."""
    parts = [pruned_lower_bounds(sp, o[s : s + chunk], i[s : s + chunk], bound[s : s + chunk])
             for s in range(0, o.shape[0], chunk)]
    return torch.cat(parts) if parts else sp.out_pos.new_zeros(0)


def _fresh(cand: torch.Tensor, field: torch.Tensor) -> torch.Tensor:
    """Mask of candidates that are neither the current match nor a repeat in their row.

    Shape: (N, C), (N,) -> (N, C) bool.
    """
    srt, order = cand.sort(1)
    first = torch.ones_like(srt, dtype=torch.bool)
    first[:, 1:] = srt[:, 1:] != srt[:, :-1]
    fresh = torch.empty_like(first).scatter_(1, order, first)
    return fresh & (cand != field[:, None])


def patchmatch(sp: PairSpace, grid: NearestGrid, field: torch.Tensor, params: SearchParams,
               window0: float, gen: torch.Generator) -> Matches:
    """Approximate nearest input neighborhoods for all output samples.

    ``field`` (N,) is the starting guess (previous iteration's field, or random/source);
    ``grid`` finds the allowed input center nearest to a place.
    """
    out_pos, in_pos = sp.out_pos[:-1], sp.in_pos[:-1]
    n = out_pos.shape[0]
    all_o = torch.arange(n)
    best, matched = distance_batched(sp, all_o, field)  # (N,), (N, K)
    field = field.clone()
    for _ in range(params.passes):
        cand = _candidates(field, out_pos, sp.out_nbr, in_pos, grid, window0, params,
                           sp.p.delta, gen, sp.torus)  # (N, C)
        fresh = _fresh(cand, field)
        oo, cc = torch.nonzero(fresh, as_tuple=True)
        lb = torch.full(cand.shape, torch.inf, dtype=best.dtype)
        lb[oo, cc] = _lower_bounds(sp, oo, cand[oo, cc], best[oo] - 1e-6)
        lb_best, j = lb.min(1)
        todo = torch.nonzero(lb_best < best - 1e-6).flatten()  # may beat the current match
        if todo.numel() == 0:
            continue
        new = cand[todo, j[todo]]
        d, m_new = distance_batched(sp, todo, new)
        better = d < best[todo]
        upd = todo[better]
        field[upd] = new[better]
        best[upd] = d[better]
        matched[upd] = m_new[better]
    return Matches(field, sp.out_nbr, matched, best)
