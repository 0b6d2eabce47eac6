"""Depth order of output clusters (seed 000 sec. 6.4, eqs. 5-8).

Matched neighborhoods vote whether one output sample lies below another (seed 000 eq. 5), the votes
are averaged over the sample pairs of two clusters (seed 000 eq. 8), and a total drawing order
follows from these pairwise preferences by Order-By-Preferences (Cohen, Schapire & Singer 1999):
strongly connected components of the majority graph in topological order, greedy by potential inside
each component. On an acyclic preference set that order agrees with every preference.
"""

from __future__ import annotations

import heapq

import numpy as np
import torch
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from cvt.pair_votes import PairVotes
from cvt.torus import Torus, offsets


def sample_order(votes: PairVotes, out_pos: torch.Tensor, delta: float, torus: Torus | None = None):
    """f_s for pairs closer than 2 delta (seed 000 eq. 5): P(a below b) and P(b below a).

    Shape: -> a, b (P,) long, f_ab, f_ba (P,) float64.
    """
    close = offsets(out_pos[votes.a] - out_pos[votes.b], torus).norm(dim=1) < 2 * delta
    v = votes.select(close)
    n = v.n.double()
    return v.a, v.b, v.below.double() / n, v.above.double() / n


def cluster_preferences(votes: PairVotes, out_pos: torch.Tensor, cluster: torch.Tensor,
                        n_clusters: int, delta: float, torus: Torus | None = None) -> np.ndarray:
    """f_C(C_i, C_j) (seed 000 eq. 8): mean f_s over close sample pairs of two clusters, 0 if none.

    ``cluster`` (N,) must hold ids 0..n_clusters-1. Shape: -> (C, C), [i, j] = P(i below j).
    """
    a, b, f_ab, f_ba = sample_order(votes, out_pos, delta, torus)
    ca, cb = cluster[a].numpy(), cluster[b].numpy()
    cross = ca != cb
    ca, cb, f_ab, f_ba = ca[cross], cb[cross], f_ab.numpy()[cross], f_ba.numpy()[cross]
    shape = (n_clusters, n_clusters)
    total = (coo_matrix((f_ab, (ca, cb)), shape) + coo_matrix((f_ba, (cb, ca)), shape)).toarray()
    ones = np.ones(len(ca))
    z = (coo_matrix((ones, (ca, cb)), shape) + coo_matrix((ones, (cb, ca)), shape)).toarray()
    return np.divide(total, z, out=np.zeros(shape), where=z > 0)


def order_by_preferences(pref: np.ndarray, key: np.ndarray | None = None) -> np.ndarray:
    """Total order (first = bottom) from pairwise preferences ``pref[u, v]`` = weight of "u
    below v". Ties and unrelated items follow ``key`` (ascending). Shape: (C, C) -> (C,)."""
    c = pref.shape[0]
    key = np.arange(c, dtype=float) if key is None else np.asarray(key, dtype=float)
    if c == 0:
        return np.zeros(0, dtype=np.int64)
    major = pref > pref.T  # (C, C) majority edges u -> v
    n_comp, comp = connected_components(coo_matrix(major), directed=True, connection="strong")
    order = []
    for k in _topological(major, comp, n_comp, key):
        order.extend(_greedy(pref, np.flatnonzero(comp == k), key))
    return np.asarray(order, dtype=np.int64)


def _topological(major: np.ndarray, comp: np.ndarray, n_comp: int, key: np.ndarray):
    """Components in an order that respects the (acyclic) condensation; Kahn by smallest key."""
    u, v = np.nonzero(major)
    cu, cv = comp[u], comp[v]
    edges = {(int(x), int(y)) for x, y in zip(cu, cv, strict=True) if x != y}
    indeg = np.zeros(n_comp, dtype=np.int64)
    succ: list[list[int]] = [[] for _ in range(n_comp)]
    for x, y in edges:
        succ[x].append(y)
        indeg[y] += 1
    ckey = np.full(n_comp, np.inf)
    np.minimum.at(ckey, comp, key)
    ready = sorted((ckey[k], k) for k in range(n_comp) if indeg[k] == 0)
    heapq.heapify(ready)
    while ready:
        _, k = heapq.heappop(ready)
        yield k
        for y in succ[k]:
            indeg[y] -= 1
            if indeg[y] == 0:
                heapq.heappush(ready, (ckey[y], y))


def _greedy(pref: np.ndarray, nodes: np.ndarray, key: np.ndarray) -> list[int]:
    """Cohen et al.'s greedy: repeatedly emit the node preferring most to be below the rest."""
    if len(nodes) == 1:
        return [int(nodes[0])]
    sub = pref[np.ix_(nodes, nodes)]
    pot = sub.sum(1) - sub.sum(0)  # (n,) potential
    alive = np.ones(len(nodes), dtype=bool)
    out = []
    for _ in range(len(nodes)):
        cand = np.flatnonzero(alive)
        best = cand[np.lexsort((key[nodes[cand]], -pot[cand]))[0]]
        out.append(int(nodes[best]))
        alive[best] = False
        pot -= sub[:, best] - sub[best, :]
    return out
