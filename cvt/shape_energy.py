"""Cluster shape energy (seed 000 eqs. 15-17): how far an output cluster is from the nearest
input cluster shape.

For an output cluster C_o the candidate input clusters are those its samples are matched to
(mu_s). Each candidate C_i is translated onto C_o by the mean offset of the matched pairs
(seed 000 eq. 17) and compared by seed 000 eq. 16: an optimal one-to-one matching of the samples
plus eps per unmatched sample, normalized by eps = 2 delta. The best candidate gives E'_s
(seed 000 eq. 15), and in reconstruction the element and its translation (sec. 6.6).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from cvt.torus import Torus


@dataclass(frozen=True)
class ShapeFit:
    energy: float  # E'_s(C_o), seed 000 eq. 15
    cluster: int  # best candidate input cluster
    shift: tuple[float, float]  # T_r translation of that candidate onto C_o (seed 000 eq. 17)


def shape_distance(p_out: np.ndarray, p_in: np.ndarray, eps: float) -> float:
    """Seed 000 eq. 16 for already translated input samples. Shape: (A, 2), (B, 2) -> scalar."""
    if len(p_out) == 0 or len(p_in) == 0:
        return abs(len(p_out) - len(p_in)) * 1.0
    d = cdist(p_out, p_in)
    r, c = linear_sum_assignment(d)
    return float(d[r, c].sum()) / eps + abs(len(p_out) - len(p_in))


class ShapeEnergy:
    """E'_s of any set of output samples under one matching field, memoized per member set.

    Shape: out_pos (N, 2), mu (N,) input sample of each output sample, in_pos (M, 2),
    in_cluster (M,).
    """

    def __init__(self, out_pos: torch.Tensor, mu: torch.Tensor, in_pos: torch.Tensor,
                 in_cluster: torch.Tensor, delta: float, torus: Torus | None = None):
        self.o_pos = out_pos.double().numpy()
        self.torus = torus  # tileable output: a cluster may lie across the seam
        self.i_pos = in_pos.double().numpy()
        self.mu = mu.numpy()
        i_cl = in_cluster.numpy()
        self.src = i_cl[self.mu]  # (N,) input cluster each output sample is matched to
        order = np.argsort(i_cl, kind="stable")
        ids, start = np.unique(i_cl[order], return_index=True)
        bounds = np.r_[start, len(order)]
        self.members = {int(c): order[bounds[k]:bounds[k + 1]] for k, c in enumerate(ids)}
        self.size = np.bincount(i_cl)  # (C_in,) samples per input cluster
        self.eps = 2 * delta
        self._memo: dict[bytes, ShapeFit] = {}

    def __call__(self, members: np.ndarray) -> ShapeFit:
        """Best candidate for the output cluster made of ``members`` (sample indices)."""
        members = np.sort(np.asarray(members, dtype=np.int64))
        tag = members.tobytes()
        fit = self._memo.get(tag)
        if fit is None:
            fit = self._memo[tag] = self._fit(members)
        return fit

    def candidates(self, members: np.ndarray) -> np.ndarray:
        """Candidate input clusters of an output cluster (seed 000 eq. 15's set). Shape: -> (K,)."""
        return np.unique(self.src[members])

    def count_floor(self, cands: np.ndarray, sizes) -> np.ndarray:
        """Lower bounds of E'_s for clusters of ``sizes`` samples whose candidates are among
        ``cands``: seed 000 eq. 16's count term for the nearest candidate size.
        Shape: (S,) -> (S,)."""
        return np.abs(self.size[cands][:, None] - np.asarray(sizes)[None, :]).min(0)

    def _fit(self, mem: np.ndarray) -> ShapeFit:
        src = self.src[mem]
        o_pos = self.o_pos[mem]  # (A, 2), next to each other on a torus
        if self.torus is not None:
            o_pos = o_pos[0] + self.torus.diff(o_pos - o_pos[0])
        cands = np.unique(src)
        sizes = self.size[cands]
        best = ShapeFit(np.inf, -1, (0.0, 0.0))
        for k in np.argsort(np.abs(sizes - len(mem)), kind="stable"):
            if abs(sizes[k] - len(mem)) >= best.energy:  # seed 000 eq. 16's count term alone loses
                break
            ci = int(cands[k])
            pairs = src == ci
            shift = (o_pos[pairs] - self.i_pos[self.mu[mem[pairs]]]).mean(0)  # seed 000 eq. 17
            d = shape_distance(o_pos, self.i_pos[self.members[ci]] + shift, self.eps)
            if d < best.energy:
                best = ShapeFit(d, ci, (float(shift[0]), float(shift[1])))
        return best
