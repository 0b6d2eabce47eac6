"""Assignment of edges and existence by votes of matched neighborhoods (seed 001 sec. 4.3.4).

Each output neighborhood n(o) matched to an input neighborhood holds pairs of output samples
(a, b) whose matched input samples are or are not joined by an input edge: a vote for or
against the output edge (a, b). The expected edge confidence is the share of votes for it
(eq. 16 with edges for samples), the expected degree of a sample the mean degree of the input
samples it was matched to (eq. 18); edges are then set greedily in decreasing confidence,
each to whichever of on / off lowers eq. 17 (eq. 22).
"""

from __future__ import annotations

import numpy as np
import torch

from cvt.curves.graph import CurveGraph, canonical_edges, edge_keys
from cvt.search import Matches


def occurrences(m: Matches) -> tuple[torch.Tensor, torch.Tensor]:
    """Output samples of each neighborhood (center first) and their matched inputs.

    Shape: -> (N, K + 1), (N, K + 1); -1 for padding (outputs) and outliers (inputs).
    """
    n = m.center.shape[0]
    outs = torch.cat([torch.arange(n)[:, None], m.out_nbr], 1)
    ins = torch.cat([m.center[:, None], m.matched], 1)
    return outs, torch.where(outs >= 0, ins, -1)


def edge_votes(m: Matches, out: CurveGraph, inp: CurveGraph, reach: float):
    """Candidate output edges with their expected confidence.

    Pairs closer than ``reach`` in some neighborhood are candidates, also those without votes
    (eq. 22 may still join two samples short of their expected degree). Shape: -> (C, 2) long,
    (C,) float.
    """
    outs, ins = occurrences(m)  # (N, K + 1)
    k1 = outs.shape[1]
    j, k = torch.triu_indices(k1, k1, 1)
    a, b = outs[:, j].flatten(), outs[:, k].flatten()  # (N * P,)
    ia, ib = ins[:, j].flatten(), ins[:, k].flatten()
    ok = (a >= 0) & (b >= 0)
    a, b, ia, ib = a[ok], b[ok], ia[ok], ib[ok]
    near = (out.pos[a] - out.pos[b]).norm(dim=1) < reach
    a, b, ia, ib = a[near], b[near], ia[near], ib[near]
    both = (ia >= 0) & (ib >= 0)
    n_in = len(inp)
    in_keys = edge_keys(inp.edges, n_in) if inp.edges.numel() else torch.zeros(0, dtype=torch.long)
    q = edge_keys(torch.stack([ia.clamp_min(0), ib.clamp_min(0)], 1), n_in)
    vote = (both & torch.isin(q, in_keys)).double()  # (P',) 1 for an input edge
    key = edge_keys(torch.stack([a, b], 1), len(out))
    uniq, inv = torch.unique(key, return_inverse=True)
    conf = torch.zeros(len(uniq), dtype=torch.float64).index_add_(0, inv, vote)
    conf /= torch.bincount(inv, minlength=len(uniq)).double()
    return torch.stack([uniq // len(out), uniq % len(out)], 1), conf


def expected_degree(m: Matches, out: CurveGraph, inp: CurveGraph,
                    deg_in: torch.Tensor | None = None) -> torch.Tensor:
    """Eq. 18: mean degree of the input samples each output sample was matched to
    (``deg_in`` (N_in,): the input degrees to use, default ``inp.degree()``).

    Shape: -> (N,) float; samples never matched keep their current degree.
    """
    outs, ins = occurrences(m)
    ok = (outs >= 0) & (ins >= 0)
    o, i = outs[ok], ins[ok]
    deg_in = (inp.degree() if deg_in is None else deg_in).double()
    total = torch.zeros(len(out), dtype=torch.float64).index_add_(0, o, deg_in[i])
    count = torch.bincount(o, minlength=len(out)).double()
    return torch.where(count > 0, total / count.clamp_min(1), out.degree().double())


def _continues(pos: np.ndarray, last: dict[int, int], a: int, b: int,
               cos_max: float = -0.3) -> bool:
    """A weakly voted edge must continue the strokes it joins, not fold back along them."""
    for x, y in ((a, b), (b, a)):
        if x in last:
            u, v = pos[last[x]] - pos[x], pos[y] - pos[x]
            if u @ v > cos_max * np.linalg.norm(u) * np.linalg.norm(v):
                return False
    return True


def assign_edges(m: Matches, out: CurveGraph, inp: CurveGraph, reach: float,
                 keep: torch.Tensor | None = None) -> torch.Tensor:
    """Greedy eq. 22 over candidates in decreasing confidence. ``keep`` (E', 2): edges that
    stay whatever the votes say (a user's strokes). Shape: -> (E, 2) long."""
    pairs, conf = edge_votes(m, out, inp, reach)
    want = expected_degree(m, out, inp).numpy()
    deg = np.zeros(len(out))
    chosen = []
    if keep is not None and keep.numel():
        np.add.at(deg, keep.flatten().numpy(), 1)
        fixed = set(edge_keys(keep, len(out)).tolist())
    else:
        fixed = set()
    dist = (out.pos[pairs[:, 0]] - out.pos[pairs[:, 1]]).norm(dim=1)
    order = np.lexsort((dist.numpy(), -conf.numpy()))  # confident first, then short
    pos = out.pos.numpy()
    last = {}  # sample -> the neighbour of its first chosen edge
    for (a, b), c in zip(pairs[order].tolist(), conf[order].tolist(), strict=True):
        if a * len(out) + b in fixed:
            continue
        on = (1 - c) ** 2 + (deg[a] + 1 - want[a]) ** 2 + (deg[b] + 1 - want[b]) ** 2
        off = c * c + (deg[a] - want[a]) ** 2 + (deg[b] - want[b]) ** 2
        if on < off and (c >= 0.5 or _continues(pos, last, a, b)):
            chosen.append((a, b))
            deg[a] += 1
            deg[b] += 1
            last.setdefault(a, b)
            last.setdefault(b, a)
    new = torch.tensor(chosen, dtype=torch.long).reshape(-1, 2)
    if keep is not None and keep.numel():
        new = torch.cat([new, keep])
    return canonical_edges(new)

