"""The clustering step (seed 000 sec. 6.5, eqs. 9-17): update output cluster ids.

Energy (seed 000 eq. 9) E = w_l E_l + w_s E_s. The link energy (seed 000 eqs. 12-13) sums, over
ordered pairs of output samples closer than lambda delta whose link confidence l is defined
(seed 000 eqs. 10-11), +-(1 - 2l): a pair inside one cluster costs 1 - 2l, a pair across
clusters 2l - 1. So joining a pair changes E_l by c = 4 (1 - 2l) (two ordered pairs, sign
flip). The shape energy (seed 000 eq. 14) sums E'_s over clusters (shape_energy.py).

Greedy optimization (sec. 6.5.2) with two priority queues, both with lazy deletion (an entry
whose samples or clusters changed since it was queued is dropped when popped, and fresh
entries are queued for everything the applied operator touched):

* P_s, sample switching, scored by link energy only: a boundary sample of a cluster (largest
  empty angular sector among its cluster's samples within 2 delta above ``boundary_gap``, our
  stand-in for the concave hull) may move to a cluster with a sample within 2 delta of it.
* P_C, cluster merge (clusters with samples within 2 delta of each other) and split (normalized
  cut on the link-confidence graph of the cluster), scored by the full E. Entries start with a
  cheap lower bound (E'_s >= 0) and get their exact value, which needs Hungarian matchings,
  only when they reach the front.

Each queue stops when its best operator does not lower E or after i_max operations (the number
of samples for P_s, of initial clusters for P_C).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np
import torch

from cvt.pair_votes import PairVotes
from cvt.shape_energy import ShapeEnergy
from cvt.spectral import normalized_cut
from cvt.torus import Torus, offsets

_TOL = 1e-9


@dataclass(frozen=True)
class ClusteringParams:
    w_l: float = 1.0  # seed 000 eq. 9
    w_s: float = 4.0  # seed 000 eq. 9
    lam: float = 4.0  # link pairs reach lambda delta (seed 000 eq. 12)
    adjacent: float = 2.0  # switch targets and merge partners reach this many delta
    boundary_gap: float = math.pi / 2  # empty sector (radians) that makes a boundary sample
    switch: bool = True
    merge: bool = True
    split: bool = True


@dataclass
class ClusteringStats:
    switches: int = 0
    merges: int = 0
    splits: int = 0
    energy: list[float] = field(default_factory=list)  # E before P_s, after P_s, after P_C


class _Csr:
    """Symmetric sparse pairs as CSR over samples, with per-entry values."""

    def __init__(self, a: np.ndarray, b: np.ndarray, n: int, *vals: np.ndarray):
        rows = np.r_[a, b]
        order = np.argsort(rows, kind="stable")
        self.indptr = np.r_[0, np.cumsum(np.bincount(rows, minlength=n))]
        self.col = np.r_[b, a][order]
        self.vals = [np.r_[v, v][order] for v in vals]

    def gather(self, rows: np.ndarray):
        """Entries of ``rows``: (row of each entry, entry index). Shape: (R,) -> (E,), (E,)."""
        start = self.indptr[rows]
        length = self.indptr[rows + 1] - start
        ends = np.cumsum(length)
        first = np.repeat(start - ends + length, length)
        return np.repeat(rows, length), first + np.arange(ends[-1] if len(ends) else 0)


def _close_pairs(pos: np.ndarray, radius: float, torus: Torus | None = None):
    """All unordered pairs closer than ``radius`` (on the ``torus``: across the seam too).
    Shape: (N, 2) -> a, b (P,)."""
    from scipy.spatial import cKDTree

    if torus is None:
        tree = cKDTree(pos)
    else:
        period = np.asarray(torus.period)
        local = torus.wrap(pos) - np.asarray(torus.origin)
        tree = cKDTree(np.where(local >= period, 0.0, local), boxsize=period)
    pairs = tree.query_pairs(radius, output_type="ndarray")
    return pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)


class Clustering:
    """State of one clustering step: labels, the link graph and the 2-delta adjacency."""

    def __init__(self, pos: torch.Tensor, labels: torch.Tensor, votes: PairVotes,
                 shape: ShapeEnergy, delta: float, params: ClusteringParams):
        self.pos = pos.double().numpy()
        self.n = len(self.pos)
        self.labels = labels.numpy().astype(np.int64).copy()
        self.p = params
        self.torus = shape.torus
        d = np.linalg.norm(offsets(self.pos[votes.a.numpy()] - self.pos[votes.b.numpy()],
                                   self.torus), axis=1)
        near = d < params.lam * delta  # seed 000 eq. 12 range
        la, lb = votes.a.numpy()[near], votes.b.numpy()[near]
        link = votes.link.numpy()[near]
        self.links = _Csr(la, lb, self.n, 4.0 * (1.0 - 2.0 * link), link)  # c, l
        self.adj = _Csr(*_close_pairs(self.pos, params.adjacent * delta, self.torus), self.n)
        self.shape = shape
        self.members: dict[int, np.ndarray] = {
            int(c): np.flatnonzero(self.labels == c) for c in np.unique(self.labels)}
        self.next_id = int(self.labels.max()) + 1 if self.n else 0

    # -- energies ---------------------------------------------------------------------------
    def link_energy(self) -> float:
        """Seed 000 eq. 12 over ordered pairs (each CSR entry is one ordered pair)."""
        rows = np.repeat(np.arange(self.n), np.diff(self.links.indptr))
        same = self.labels[rows] == self.labels[self.links.col]
        c = self.links.vals[0] / 4.0  # 1 - 2l
        return float(np.where(same, c, -c).sum())

    def shape_energy(self) -> float:
        return float(sum(self.shape(m).energy for m in self.members.values()))

    def energy(self) -> float:
        """Seed 000 eq. 9."""
        return self.p.w_l * self.link_energy() + self.p.w_s * self.shape_energy()

    def _link_between(self, src: np.ndarray, label: int) -> float:
        """Sum of c over linked pairs from samples ``src`` to samples labeled ``label``."""
        rows, e = self.links.gather(src)
        hit = self.labels[self.links.col[e]] == label
        return float(self.links.vals[0][e][hit].sum())

    # -- sample switching (P_s) -------------------------------------------------------------
    def _boundary(self, rows: np.ndarray) -> np.ndarray:
        """Boundary test: largest empty angular sector among same-cluster samples within the
        adjacency radius exceeds ``boundary_gap``. Shape: (R,) unique -> (R,) bool."""
        r, e = self.adj.gather(rows)
        c = self.adj.col[e]
        same = self.labels[r] == self.labels[c]
        r, c = r[same], c[same]
        ang = np.arctan2(*offsets(self.pos[c] - self.pos[r], self.torus).T[::-1])
        order = np.lexsort((ang, r))
        r, ang = r[order], ang[order]
        gap = np.full(self.n, 2 * np.pi)
        if len(r):
            first = np.r_[True, r[1:] != r[:-1]]
            last = np.r_[r[1:] != r[:-1], True]
            inner = np.r_[0.0, np.diff(ang)]
            inner[first] = 0.0
            wrap = ang[last] - ang[first] - 2 * np.pi  # -(gap across +-pi)
            starts = np.flatnonzero(first)
            gap_in = np.maximum.reduceat(inner, starts)
            gap[r[first]] = np.maximum(gap_in, -wrap)
        return gap[rows] > self.p.boundary_gap

    def _switch_ops(self, rows: np.ndarray):
        """All switches of boundary samples among ``rows`` to adjacent clusters, with their
        link-energy change. Shape: -> sample, target, delta (S,)."""
        rows = rows[self._boundary(rows)]
        r, e = self.adj.gather(rows)
        t = self.labels[self.adj.col[e]]
        other = t != self.labels[r]
        if not other.any():
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
        key = np.unique(np.stack([r[other], t[other]], 1), axis=0)  # (S, 2) sample, target
        s_, t_ = key[:, 0], key[:, 1]
        span = self.next_id + 1
        lr, le = self.links.gather(np.unique(s_))
        lk, inv = np.unique(lr * span + self.labels[self.links.col[le]], return_inverse=True)
        sums = np.bincount(inv, weights=self.links.vals[0][le], minlength=len(lk))

        def total(k: np.ndarray) -> np.ndarray:  # sum of c from a sample to one label
            if len(lk) == 0:
                return np.zeros(len(k))
            at = np.searchsorted(lk, k).clip(max=len(lk) - 1)
            return np.where(lk[at] == k, sums[at], 0.0)

        delta = total(s_ * span + t_) - total(s_ * span + self.labels[s_])
        return s_, t_, self.p.w_l * delta

    def run_switching(self, stats: ClusteringStats) -> None:
        version = np.zeros(self.n, dtype=np.int64)
        heap: list = []

        def push(rows):
            for s, t, d in zip(*(x.tolist() for x in self._switch_ops(rows)), strict=True):
                if d < -_TOL:
                    heap.append((d, s, t, int(version[s])))

        push(np.arange(self.n))
        heapq.heapify(heap)
        while heap and stats.switches < self.n:
            d, s, t, v = heapq.heappop(heap)
            if v != version[s] or t not in self.members:
                continue
            old = int(self.labels[s])
            self._move(np.array([s]), old, t)
            stats.switches += 1
            _, e1 = self.links.gather(np.array([s]))
            _, e2 = self.adj.gather(np.array([s]))
            touched = np.unique(np.r_[s, self.links.col[e1], self.adj.col[e2]])
            version[touched] += 1
            for op in zip(*(x.tolist() for x in self._switch_ops(touched)), strict=True):
                if op[2] < -_TOL:
                    heapq.heappush(heap, (op[2], op[0], op[1], int(version[op[0]])))

    def _move(self, samples: np.ndarray, old: int, new: int) -> None:
        self.labels[samples] = new
        keep = self.members[old][~np.isin(self.members[old], samples)]
        if len(keep):
            self.members[old] = keep
        else:
            del self.members[old]
        self.members[new] = np.sort(np.r_[self.members.get(new, np.zeros(0, np.int64)),
                                          samples])

    # -- merge and split (P_C) --------------------------------------------------------------
    def _label_pairs(self, csr: _Csr):
        """Entries of ``csr`` between different clusters, each unordered sample pair once.

        Shape: -> cluster a < cluster b (P,), entry index (P,).
        """
        rows = np.repeat(np.arange(self.n), np.diff(csr.indptr))
        la, lb = self.labels[rows], self.labels[csr.col]
        keep = la < lb
        return la[keep], lb[keep], np.flatnonzero(keep)

    def _neighbors(self, cid: int) -> set[int]:
        _, e = self.adj.gather(self.members[cid])
        return set(np.unique(self.labels[self.adj.col[e]]).tolist()) - {cid}

    def _es(self, mem: np.ndarray) -> float:
        return self.shape(mem).energy

    def _cands(self, cid: int) -> np.ndarray:
        if cid not in self._cand_memo:
            self._cand_memo[cid] = self.shape.candidates(self.members[cid])
        return self._cand_memo[cid]

    def _merge_op(self, a: int, b: int, link: float | None = None):
        """Merge a and b; ``link`` = sum of c between them when already known."""
        if link is None:
            link = self._link_between(self.members[a], b)
        dl = self.p.w_l * link
        es = self._es(self.members[a]) + self._es(self.members[b])
        n = len(self.members[a]) + len(self.members[b])
        cands = np.union1d(self._cands(a), self._cands(b))
        bound = dl + self.p.w_s * (float(self.shape.count_floor(cands, [n])[0]) - es)
        if bound >= -_TOL:
            return None

        def exact():
            merged = np.concatenate([self.members[a], self.members[b]])
            return dl + self.p.w_s * (self._es(merged) - es)

        return bound, ("merge", (a, b), exact)

    def _split_op(self, a: int):
        mem = self.members[a]
        if len(mem) < 2:
            return None
        rows, e = self.links.gather(mem)
        col = self.links.col[e]
        inside = self.labels[col] == a
        es = self._es(mem)
        # Before the cut: E_l can drop at most by the positive c inside (each pair twice in
        # the CSR), E'_s of the parts by no less than their count terms.
        cands = self._cands(a)
        g = self.shape.count_floor(cands, np.arange(1, len(mem)))  # part sizes 1..|C|-1
        c = self.links.vals[0][e][inside]
        dl_min = -self.p.w_l * 0.5 * float(c[c > 0].sum())
        if dl_min + self.p.w_s * (float((g + g[::-1]).min()) - es) >= -_TOL:
            return None
        local = np.full(self.n, -1)
        local[mem] = np.arange(len(mem))
        w = np.zeros((len(mem), len(mem)))
        w[local[rows[inside]], local[col[inside]]] = self.links.vals[1][e][inside]  # l
        side = normalized_cut(w)
        part1, part2 = mem[side], mem[~side]
        cross = inside & side[local[rows]] & ~side[local[col].clip(min=0)]
        dl = -self.p.w_l * float(self.links.vals[0][e][cross].sum())
        bound = dl + self.p.w_s * (float(g[len(part1) - 1] + g[len(part2) - 1]) - es)
        if bound >= -_TOL:
            return None

        def exact():
            return dl + self.p.w_s * (self._es(part1) + self._es(part2) - es)

        return bound, ("split", (a,), exact, part1, part2)

    def _initial_ops(self, push) -> None:
        if self.p.merge:
            la, lb, e = self._label_pairs(self.links)
            span = self.next_id + 1
            lk, inv = np.unique(la * span + lb, return_inverse=True)
            sums = np.bincount(inv, weights=self.links.vals[0][e], minlength=len(lk))
            ka, kb, _ = self._label_pairs(self.adj)
            adjacent = np.unique(ka * span + kb)
            at = np.searchsorted(lk, adjacent).clip(max=max(len(lk) - 1, 0))
            hit = (lk[at] == adjacent) if len(lk) else np.zeros(len(adjacent), bool)
            link = np.where(hit, sums[at] if len(lk) else 0.0, 0.0)
            for key, c in zip(adjacent.tolist(), link.tolist(), strict=True):
                push(self._merge_op(key // span, key % span, c))
        if self.p.split:
            for c in sorted(self.members):
                push(self._split_op(c))

    def run_merge_split(self, stats: ClusteringStats) -> None:
        heap: list = []
        tick = 0  # tie breaker: heap entries never compare their payloads
        self._cand_memo: dict[int, np.ndarray] = {}

        def push(op):
            nonlocal tick
            if op is not None:
                heapq.heappush(heap, (op[0], tick, False, op[1]))
                tick += 1

        self._initial_ops(push)
        i_max = len(self.members)
        while heap and stats.merges + stats.splits < i_max:
            value, _, is_exact, op = heapq.heappop(heap)
            if value >= -_TOL:
                break
            if not all(c in self.members for c in op[1]):
                continue  # a cluster it involves has changed since
            if not is_exact:
                heapq.heappush(heap, (op[2](), tick, True, op))
                tick += 1
                continue
            for cid in self._apply(op, stats):
                if self.p.split:
                    push(self._split_op(cid))
                if self.p.merge:
                    for other in self._neighbors(cid):
                        push(self._merge_op(cid, other))

    def _apply(self, op, stats: ClusteringStats) -> list[int]:
        """Apply a merge or split; returns the new cluster ids."""
        if op[0] == "merge":
            a, b = op[1]
            new = self.next_id
            self.next_id += 1
            mem = np.sort(np.r_[self.members.pop(a), self.members.pop(b)])
            self.members[new] = mem
            self.labels[mem] = new
            stats.merges += 1
            return [new]
        (a,), part1, part2 = op[1], op[3], op[4]
        del self.members[a]
        ids = [self.next_id, self.next_id + 1]
        self.next_id += 2
        for cid, part in zip(ids, (part1, part2), strict=True):
            self.members[cid] = part
            self.labels[part] = cid
        stats.splits += 1
        return ids


def cluster_step(pos: torch.Tensor, labels: torch.Tensor, votes: PairVotes,
                 shape: ShapeEnergy, delta: float,
                 params: ClusteringParams) -> tuple[torch.Tensor, ClusteringStats]:
    """Greedy minimization of seed 000 eq. 9 over cluster ids: P_s, then P_C.

    Shape: pos (N, 2), labels (N,) -> new labels (N,) long (ids 0..C-1), stats.
    """
    state = Clustering(pos, labels, votes, shape, delta, params)
    stats = ClusteringStats(energy=[state.energy()])
    if params.switch and params.w_l > 0:
        state.run_switching(stats)
    stats.energy.append(state.energy())
    if params.merge or params.split:
        state.run_merge_split(stats)
    stats.energy.append(state.energy())
    compact = np.unique(state.labels, return_inverse=True)[1]
    return torch.from_numpy(compact.astype(np.int64)), stats


def changed_samples(old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
    """Samples whose cluster (as a member set) is not one of the old clusters.

    Shape: old (N,), new (N,) labels -> (N,) bool.
    """
    _, o = torch.unique(old, return_inverse=True)
    _, c = torch.unique(new, return_inverse=True)
    k = int(c.max()) + 1 if len(c) else 0
    lo = torch.full((k,), len(o), dtype=torch.long).scatter_reduce(0, c, o, "amin")
    hi = torch.full((k,), -1, dtype=torch.long).scatter_reduce(0, c, o, "amax")
    same_size = torch.bincount(c, minlength=k) == torch.bincount(o)[lo.clamp_max(len(o) - 1)]
    kept = (lo == hi) & same_size  # (K,) one old cluster, all of it
    return ~kept[c]
