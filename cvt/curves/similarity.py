"""Sample similarity of curve samples as the feature table of cvt's neighborhood distance.

cvt's batched eq. 2 / seed 001 eq. 7 adds ``table[o, i]`` (times w_f / 2) to the position
term of every sample pair it matches, so the curve attributes enter there:

* edges (seed 001 eq. 5), two ways (``edge_term``):
  ``"embedding"``: the edge set of a sample is embedded as a sum of von Mises bumps on a ring
  of direction bins, one unit-norm bump per edge; the squared distance of two such sums is
  small when the edges can be matched one to one with similar directions and grows by about 1
  (= lambda, one sampling distance) per unmatched edge; its table is one matrix product.
  ``"matching"``: eq. 5 itself: the edge vectors (in sampling distances) of the two samples
  are matched one to one by the assignment of least total squared difference (an exact
  minimum over permutations, edge sets up to ``MAX_EDGES``: far cheaper than a Hungarian
  solver per pair at these sizes), plus lambda = 1 per edge left unmatched.
  Samples without edges (new ones) get no edge term (seed 001: lambda = 0 for them).
* style (eq. 3 attribute term): a constant when the stroke styles differ.
* ids (eq. 4, sec. 4.2.3): curve samples only match curve samples and discrete elements only
  the same kind; a mismatch costs ``forbid``, above any outlier cost.
"""

from __future__ import annotations

import itertools
import math

import torch

from cvt.curves.graph import CurveGraph

BINS = 12
KAPPA = 3.0
MAX_EDGES = 4  # eq. 5 matching: a sample's first edges (crossings have 4; more are rare)
CHUNK = 256  # output rows per block of the eq. 5 table


def edge_embedding(g: CurveGraph) -> torch.Tensor:
    """Sum over a sample's edges of unit-norm direction bumps. Shape: -> (N, BINS)."""
    emb = torch.zeros(len(g), BINS, dtype=torch.float64)
    if g.edges.numel() == 0:
        return emb
    a, b = g.edges[:, 0], g.edges[:, 1]
    src = torch.cat([a, b])
    d = torch.cat([g.pos[b] - g.pos[a], g.pos[a] - g.pos[b]])  # (2E, 2) outgoing directions
    ang = torch.atan2(d[:, 1], d[:, 0])
    centers = torch.arange(BINS, dtype=torch.float64) * (2 * math.pi / BINS)
    bump = torch.exp(KAPPA * (torch.cos(ang[:, None] - centers[None]) - 1))  # (2E, BINS)
    bump = bump / bump.norm(dim=1, keepdim=True)
    return emb.index_add_(0, src, bump)


def edge_sets(g: CurveGraph, delta: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Each sample's edge vectors in units of ``delta`` (its first ``MAX_EDGES``) and which
    slots hold one. Shape: -> (N, MAX_EDGES, 2), (N, MAX_EDGES) bool."""
    n = len(g)
    u = torch.zeros(n, MAX_EDGES, 2, dtype=torch.float64)
    has = torch.zeros(n, MAX_EDGES, dtype=torch.bool)
    if g.edges.numel() == 0:
        return u, has
    a, b = g.edges[:, 0], g.edges[:, 1]
    src = torch.cat([a, b])
    vec = torch.cat([g.pos[b] - g.pos[a], g.pos[a] - g.pos[b]]) / delta  # (2E, 2)
    order = torch.argsort(src, stable=True)
    src, vec = src[order], vec[order]
    slot = torch.arange(len(src)) - torch.searchsorted(src, torch.arange(n))[src]
    ok = slot < MAX_EDGES
    u[src[ok], slot[ok]] = vec[ok]
    has[src[ok], slot[ok]] = True
    return u, has


def _matched(uo, ho, ui, hi, lam: float) -> torch.Tensor:
    """Eq. 5 for every pair of two blocks with ``d`` edge slots: the least total over one-to-one
    matchings (all permutations of the slots) of the pair costs, a matched pair of edges
    costing their squared difference (at most 2 lambda: never worse than both unmatched), an
    edge facing an empty slot lambda. Shape: (A, d, 2), (A, d), (B, d, 2), (B, d) -> (A, B)."""
    d = uo.shape[1]
    out = torch.empty(len(uo), len(ui), dtype=torch.float64)
    norm_i = (ui * ui).sum(-1)  # (B, d)
    for s in range(0, len(uo), CHUNK):
        a, ha = uo[s : s + CHUNK], ho[s : s + CHUNK]
        norm_a = (a * a).sum(-1)
        cost = {}  # slot pair (j, k) -> (c, B) cost of matching edge j to edge k
        for j in range(d):
            for k in range(d):
                sq = norm_a[:, j, None] + norm_i[None, :, k] - 2 * a[:, j] @ ui[:, k].T
                both = ha[:, j, None] & hi[None, :, k]
                one = ha[:, j, None] ^ hi[None, :, k]
                cost[j, k] = torch.where(both, sq.clamp(0, 2 * lam), one.double() * lam)
        best = None
        for perm in itertools.permutations(range(d)):
            total = sum(cost[j, k] for j, k in enumerate(perm))
            best = total if best is None else torch.minimum(best, total)
        out[s : s + CHUNK] = best
    return out


def edge_set_distance(uo, ho, ui, hi, lam: float = 1.0) -> torch.Tensor:
    """Eq. 5's edge set difference of every (output, input) pair (``edge_sets``), in blocks
    by edge count: a pair needs only as many slots as the larger of its two sets (2 and 2
    permutations inside a stroke, 3 and 6 at a fork, ``MAX_EDGES`` and 24 at a crossing).
    Shape: -> (N_out, N_in)."""
    table = torch.empty(len(uo), len(ui), dtype=torch.float64)
    size_o = ho.sum(1).clamp(2, MAX_EDGES)
    size_i = hi.sum(1).clamp(2, MAX_EDGES)
    for k_o in range(2, MAX_EDGES + 1):
        io = torch.nonzero(size_o == k_o).flatten()
        for k_i in range(2, MAX_EDGES + 1):
            ii = torch.nonzero(size_i == k_i).flatten()
            if len(io) == 0 or len(ii) == 0:
                continue
            d = max(k_o, k_i)
            table[io[:, None], ii[None]] = _matched(uo[io, :d], ho[io, :d], ui[ii, :d],
                                                    hi[ii, :d], lam)
    return table


def feature_table(out: CurveGraph, inp: CurveGraph, w_edge: float = 1.0, w_style: float = 1.0,
                  forbid: float = 100.0, in_emb=None, edge_term: str = "embedding",
                  delta: float = 1.0) -> torch.Tensor:
    """Attribute cost of every (output, input) sample pair; ``in_emb``: the input's
    ``edge_embedding`` (or its ``edge_sets`` for ``edge_term="matching"``, at ``delta``) if
    the caller has it. Shape: -> (N_out, N_in)."""
    table = torch.zeros(len(out), len(inp), dtype=torch.float64)
    if w_edge > 0 and edge_term == "matching":
        ui, hi = edge_sets(inp, delta) if in_emb is None else in_emb
        table += w_edge * edge_set_distance(*edge_sets(out, delta), ui, hi)
        table[out.degree() == 0] = 0.0  # new samples: lambda = 0, eq. 5 vanishes
    elif w_edge > 0:
        e_in = edge_embedding(inp) if in_emb is None else in_emb
        e_out = edge_embedding(out)
        table += w_edge * torch.cdist(e_out, e_in) ** 2
        table[out.degree() == 0] = 0.0  # new samples: lambda = 0, eq. 5 vanishes
    if w_style > 0:
        table += w_style * (out.style[:, None] != inp.style[None]).double()
    table += forbid * (out.kind[:, None] != inp.kind[None]).double()
    return table
