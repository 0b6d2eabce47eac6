"""Assignment step: positions by least squares over votes, and existence (add missing samples).

Positions (seed 000 eq. 18, seed 001 eq. 15): every matched pair (s'_o -> s'_i) inside a
matched neighborhood pair (s_o -> s_i) votes that p(s_o) - p(s'_o) should equal
p(s_i) - p(s'_i). We minimize the sum of squared vote residuals plus a small pull ``mu`` towards
the current positions (fixes the free translation) with conjugate gradients on the graph
Laplacian, all in torch.

Existence (seed 001 sec. 4.3.4): input samples of a matched input neighborhood that no output
sample matched vote for a missing output sample at the corresponding place; places whose share
of votes among the overlapping output neighborhoods exceeds 1/2 get a new sample. CVT only adds
(seed 000 appendix A.2.2); the filtering step (cvt.reconstruction) removes surplus samples later.
"""

from __future__ import annotations

import warnings

import torch

from cvt.sampling import Samples
from cvt.search import Matches
from cvt.torus import Torus


def _votes(out_n: int, m: Matches, in_pos: torch.Tensor):
    """Edges (a, b) with desired difference p(a) - p(b). Shape: -> (E,), (E,), (E, 2)."""
    a = torch.arange(out_n)[:, None].expand_as(m.out_nbr)  # (N, K)
    ok = m.matched >= 0
    a, b = a[ok], m.out_nbr[ok]
    want = in_pos[m.center[:, None].expand_as(m.matched)[ok]] - in_pos[m.matched[ok]]  # (E, 2)
    return a, b, want


def assign_positions(pos: torch.Tensor, m: Matches, in_pos: torch.Tensor, mu: float = 0.05,
                     huber: float | None = None, iters: int = 80,
                     tol: float = 1e-12, torus: Torus | None = None,
                     anchor: tuple[torch.Tensor, torch.Tensor, float] | None = None
                     ) -> torch.Tensor:
    """Least-squares positions (seed 000 eq. 18). Shape: pos (N, 2) -> (N, 2).

    Solves (L + mu I) p = B^T W w + mu p_old by conjugate gradients, L the weighted Laplacian
    of the vote edges as a sparse CSR matrix. With ``huber`` (a length, e.g. delta) a vote
    whose residual at the current positions exceeds it is down-weighted by huber / residual
    (one reweighting step of a Huber fit), so a few bad matches cannot drag whole clusters.
    Consistent votes (w == p_old differences) give p == p_old. On a ``torus`` a vote across
    the seam keeps the whole periods between its (unwrapped) samples.
    """
    n = pos.shape[0]
    a, b, want = _votes(n, m, in_pos)
    if a.numel() == 0 and anchor is None:
        return pos.clone()
    dt = torch.float64
    want = want.to(dt)
    x = pos.to(dt)
    if torus is not None:
        d = x[a] - x[b]
        want = want + (d - torus.diff(d))
    wt = torch.ones(a.numel(), dtype=dt)
    if huber is not None:
        resid = ((x[a] - x[b]) - want).norm(dim=1)
        wt = (huber / resid.clamp_min(1e-12)).clamp_max(1.0)
    want = want * wt[:, None]
    ar = torch.arange(n)
    rows = torch.cat([a, b, a, b, ar])
    cols = torch.cat([a, b, b, a, ar])
    diag = torch.full((n,), mu, dtype=dt)
    rhs = mu * x
    if anchor is not None:
        idx, target, weight = anchor
        diag = diag.index_add(0, idx, torch.full((len(idx),), weight, dtype=dt))
        rhs = rhs.index_add(0, idx, weight * target.to(dt))
    vals = torch.cat([wt, wt, -wt, -wt, diag])
    with warnings.catch_warnings():  # "sparse CSR is beta" is not news to us
        warnings.simplefilter("ignore", UserWarning)
        lap = torch.sparse_coo_tensor(torch.stack([rows, cols]), vals, (n, n)).coalesce()
        lap = lap.to_sparse_csr()
    rhs = rhs.index_add(0, a, want).index_add(0, b, -want)  # (N, 2)
    return _cg(lambda v: lap @ v, rhs, x.clone(), iters, tol).to(pos.dtype)


def _cg(apply, rhs: torch.Tensor, x: torch.Tensor, iters: int, tol: float) -> torch.Tensor:
    """Conjugate gradients for an SPD operator, both columns of (N, 2) at once."""
    r = rhs - apply(x)
    d = r.clone()
    rs = (r * r).sum(0)  # (2,)
    stop = tol * (rhs * rhs).sum(0).clamp_min(1e-30)
    for _ in range(iters):
        if bool((rs <= stop).all()):
            break
        ad = apply(d)
        alpha = rs / (d * ad).sum(0).clamp_min(1e-300)
        x = x + alpha * d
        r = r - alpha * ad
        rs_new = (r * r).sum(0)
        d = r + (rs_new / rs.clamp_min(1e-300)) * d
        rs = rs_new
    return x


def missing_votes(out: Samples, m: Matches, inp: Samples, in_nbr: torch.Tensor,
                  radius: float = float("inf")):
    """Positions and sources of input neighbors (within ``radius`` of their center) left
    unmatched in matched neighborhoods.

    Shape: -> pos (V, 2), input sample (V,), voting output center (V,).
    """
    nb = in_nbr[m.center]  # (N, K) input neighborhood of each match
    hit = (nb[:, :, None] == m.matched[:, None, :]).any(2)  # (N, K) matched by someone
    near = (inp.pos[nb.clamp_min(0)] - inp.pos[m.center][:, None]).norm(dim=-1) <= radius
    miss = (nb >= 0) & ~hit & near
    s_o = torch.arange(len(out))[:, None].expand_as(nb)[miss]  # (V,)
    s_i = nb[miss]  # (V,)
    p = out.pos[s_o] + (inp.pos[s_i] - inp.pos[m.center[s_o]])  # (V, 2)
    return p, s_i, s_o


def add_missing(out: Samples, m: Matches, inp: Samples, in_nbr: torch.Tensor, delta: float,
                radius: float, bounds: tuple[float, float, float, float],
                threshold: float = 0.5, min_gap: float = 0.9,
                min_new: float = 0.5, torus: Torus | None = None) -> Samples:
    """Existence assignment, additions only. Returns the new samples (possibly empty).

    A new sample copies z, feature and element from the input sample that voted for it; its
    cluster is the output cluster that the same neighborhood matched to that input cluster, or
    a fresh id.
    """
    p, s_i, s_o = missing_votes(out, m, inp, in_nbr, radius)
    x0, y0, x1, y1 = bounds
    if torus is None:
        inside = (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)
        p, s_i, s_o = p[inside], s_i[inside], s_o[inside]
    else:  # the votes of one place must meet in one cell: on the canvas
        p = torus.wrap(p)
    if p.shape[0] == 0:
        return out.select(torch.zeros(0, dtype=torch.long))
    uniq, inv, place, first_vote = _places(p, delta, torus)
    # seed 001 eq. 16 counts neighborhoods, so a neighborhood voting twice for one place counts once
    voter = torch.unique(inv * len(out) + s_o)  # distinct (place, voting center) pairs
    counts = torch.bincount(voter // len(out), minlength=len(uniq))
    # Overlapping output neighborhoods: output samples within r of the place (seed 001 eq. 16
    # denominator).
    near = torch.cdist(place, out.pos) if torus is None else torus.cdist(place, out.pos)  # (P, N)
    # counted in row chunks: summing a (P, N) bool casts it whole to int64 first
    overlap = torch.cat([(c <= radius).sum(1) for c in near.split(1024)]).clamp_min(1)
    xi = counts / overlap
    keep = (xi > threshold) & (near.min(1).values >= min_gap * delta)
    keep_idx = torch.nonzero(keep).flatten()
    keep_idx = keep_idx[torch.argsort(xi[keep_idx], descending=True, stable=True)]
    chosen = _spaced(place[keep_idx].tolist(), min_gap * delta, torus)
    chosen = [int(keep_idx[c]) for c in chosen]
    chosen_pos = [place[c] for c in chosen]
    if not chosen:
        return out.select(torch.zeros(0, dtype=torch.long))
    v = first_vote[torch.tensor(chosen)]  # (A,) one representative vote per new sample
    cluster = _new_cluster_ids(out, m, inp, s_i[v], s_o[v], 2 * delta, torus)
    # A fresh cluster must bring at least ``min_new`` of its input element's samples at once:
    # stray one- or two-sample clusters would each rebuild a whole element (no clustering
    # step yet to merge them). ``min_new`` >= 1 disables fresh clusters.
    fresh = cluster > out.cluster.max()
    if fresh.any():
        _, grp, size = torch.unique(cluster[fresh], return_inverse=True, return_counts=True)
        full = torch.bincount(inp.cluster)[inp.cluster[s_i[v[fresh]]]]  # (F,) element sizes
        ok = torch.ones_like(fresh)
        ok[fresh] = size[grp] >= min_new * full
        v, cluster = v[ok], cluster[ok]
        chosen = [c for c, k in zip(chosen, ok.tolist(), strict=True) if k]
        chosen_pos = [q for q, k in zip(chosen_pos, ok.tolist(), strict=True) if k]
        if not chosen:
            return out.select(torch.zeros(0, dtype=torch.long))
    return Samples(torch.stack(chosen_pos), cluster, inp.z[s_i[v]],
                   xi[torch.tensor(chosen)].to(p.dtype), inp.feat[s_i[v]], inp.element[s_i[v]],
                   s_i[v])


def _places(p: torch.Tensor, delta: float, torus: Torus | None):
    """Votes landing in one cell (side ``delta``) are one place, at their mean. On a
    ``torus`` (votes on the canvas) the cells tile the period: side period / floor(period /
    delta), where cells of side ``delta`` from the origin left a sliver of a cell at the seam
    that caught a fraction of the votes of the places it cut. Shape: p (V, 2) -> uniq (U,),
    inv (V,), place (U, 2), first_vote (U,)."""
    if torus is None:
        cell = torch.floor(p / delta).long()  # (V, 2)
    else:
        n = torch.clamp(torch.floor(p.new_tensor(torus.period) / delta), min=1)  # (2,)
        side = p.new_tensor(torus.period) / n
        cell = (torch.floor((p - p.new_tensor(torus.origin)) / side) % n).long()
    key = (cell[:, 0] - cell[:, 0].min()) * (int(cell[:, 1].max() - cell[:, 1].min()) + 1) + (
        cell[:, 1] - cell[:, 1].min())
    uniq, inv, n_votes = torch.unique(key, return_inverse=True, return_counts=True)
    place = torch.zeros(len(uniq), 2, dtype=p.dtype).index_add_(0, inv, p) / n_votes[:, None]
    first_vote = torch.full((len(uniq),), -1, dtype=torch.long)
    first_vote.scatter_reduce_(0, inv, torch.arange(len(inv)), reduce="amin", include_self=False)
    return uniq, inv, place, first_vote


def _spaced(points: list[list[float]], gap: float, torus: Torus | None = None) -> list[int]:
    """Greedy in order: indices of points kept at least ``gap`` apart (grid hash, cells of
    side >= gap); on a ``torus`` (points on the canvas) by the minimum image and with the
    cells wrapping around, so two points across the seam are close too."""
    origin, period = (0.0, 0.0), (None, None)
    if torus is not None:
        origin, period = torus.origin, torus.period
    n = [None if q is None else max(1, int(q // gap)) for q in period]  # cells per period
    side = [gap if q is None else q / c for q, c in zip(period, n, strict=True)]

    def cell(v: float, a: int) -> int:
        c = int((v - origin[a]) // side[a])
        return c if n[a] is None else c % n[a]

    def close(d: tuple[float, float]) -> bool:
        d = [x if q is None else x - q * round(x / q) for x, q in zip(d, period, strict=True)]
        return d[0] ** 2 + d[1] ** 2 < gap * gap

    grid: dict[tuple[int, int], list[tuple[float, float]]] = {}
    kept = []
    for k, (x, y) in enumerate(points):
        ci, cj = cell(x, 0), cell(y, 1)
        cells = {(ci + di if n[0] is None else (ci + di) % n[0],
                  cj + dj if n[1] is None else (cj + dj) % n[1])
                 for di in (-1, 0, 1) for dj in (-1, 0, 1)}
        if any(close((qx - x, qy - y)) for c in cells for qx, qy in grid.get(c, ())):
            continue
        grid.setdefault((ci, cj), []).append((x, y))
        kept.append(k)
    return kept


def _new_cluster_ids(out: Samples, m: Matches, inp: Samples, s_i, s_o, cell: float,
                     torus: Torus | None = None):
    """Cluster of each new sample: join the output cluster its neighborhood mapped to the same
    input cluster, else a fresh id shared by the new samples of the same input cluster placed
    with (about) the same translation, i.e. the same missing element; on a ``torus``
    translations are equal modulo the periods (voters on either side of the seam place one
    element; split, its halves each missed ``min_new`` and the seam kept a gap). Shape: (A,)
    -> (A,)."""
    want = inp.cluster[s_i]  # (A,)
    mt = m.matched[s_o]  # (A, K)
    mc = torch.where(mt >= 0, inp.cluster[mt.clamp_min(0)], -1)  # (A, K)
    same = mc == want[:, None]
    has = same.any(1)
    first = same.float().argmax(1)
    joined = out.cluster[m.out_nbr[s_o, first].clamp_min(0)]
    # The center itself also counts when its own match is in that input cluster.
    center_same = inp.cluster[m.center[s_o]] == want
    joined = torch.where(center_same, out.cluster[s_o], joined)
    has = has | center_same
    shift = out.pos[s_o] - inp.pos[m.center[s_o]]  # (A, 2) where the input pattern sits
    if torus is not None:
        shift = torus.wrap(shift)
    key = torch.cat([want[:, None], torch.round(shift / cell).long()], 1)  # (A, 3)
    _, group = torch.unique(key, dim=0, return_inverse=True)
    fresh = int(out.cluster.max()) + 1 + group
    return torch.where(has, joined, fresh)
