"""Texton groups: the textons that make one object, arranged as one element.

A fitted texture describes one coin by a score of textons (rim arcs, the face, its shading),
and since detail sprites (:mod:`neuraltex.texton_detail`) were fitted jointly, each texton's
sprite only makes sense beside its neighbours. Arranged one by one, the textons of different
coins mix into blobs of arcs. So :mod:`neuraltex.texton_synthesis` arranges *groups*: textons
are joined, closest pairs first, while their Gaussians overlap

    (mu_i - mu_j)^T (U_i + U_j)^-1 (mu_i - mu_j) <= REACH^2

(the Mahalanobis distance of the difference of two Gaussians, seed 003 eq. 4.2), unless the
joined group's box (the M = ``BOX_LEVEL`` boxes of its textons) would exceed ``EXTENT`` of the
canvas's short side: separate objects (coins, beans, spots) become one group each; a texture
of touching pieces (bark, grass) is cut into patches of at most that size.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import Tensor

from neuraltex.textons import Textons

REACH = 2.5  # Mahalanobis distance under U_i + U_j at which two textons join
EXTENT = 0.3  # a group's box side at most, share of the canvas's short side
BOX_LEVEL = 2.0  # a texton's box: its M = 2 ellipse (cvt.gaussians.LEVEL)


def texton_boxes(mu: np.ndarray, cov: np.ndarray, level: float = BOX_LEVEL) -> np.ndarray:
    """Axis-aligned boxes (x0, y0, x1, y1) of the M = ``level`` ellipses. Shape: mu (E, 2),
    cov (E, 2, 2) -> (E, 4)."""
    half = level * np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0, None))  # (E, 2)
    return np.concatenate([mu - half, mu + half], 1)


def texton_groups(textons: Textons, rows: Tensor, reach: float = REACH,
                  extent: float = EXTENT) -> list[list[int]]:
    """Groups of the textons ``rows`` (E,) of set 0, as lists of positions into ``rows`` in
    their order (draw order when ``rows`` is), groups ordered by their first member."""
    mu = textons.mu[0, rows].detach().cpu().double().numpy()  # (E, 2)
    cov = textons.cov[0, rows].detach().cpu().double().numpy()  # (E, 2, 2)
    box = texton_boxes(mu, cov)
    d = torch.from_numpy(mu[:, None] - mu[None])  # (E, E, 2)
    s = torch.from_numpy(cov[:, None] + cov[None])  # (E, E, 2, 2)
    m2 = (d.unsqueeze(-2) @ torch.linalg.solve(s, d.unsqueeze(-1))).squeeze((-1, -2)).numpy()
    i, j = np.nonzero(np.triu(m2 <= reach * reach, 1))
    limit = extent * min(textons.canvas)
    parent = list(range(len(mu)))

    def root(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for k in np.argsort(m2[i, j], kind="stable"):
        a, b = root(int(i[k])), root(int(j[k]))
        if a == b:
            continue
        joined = np.r_[np.minimum(box[a, :2], box[b, :2]), np.maximum(box[a, 2:], box[b, 2:])]
        if max(joined[2] - joined[0], joined[3] - joined[1]) > limit:
            continue
        parent[b], box[a] = a, joined
    groups: dict[int, list[int]] = {}
    for e in range(len(mu)):
        groups.setdefault(root(e), []).append(e)
    return sorted(groups.values(), key=lambda g: g[0])


def group_kinds(textons: Textons, rows: Tensor, groups: list[list[int]],
                size_ratio: float = 4.0) -> np.ndarray:
    """A kind per group for cvt's density repair: its area bin (the summed areas of its
    textons, bins a factor of ``size_ratio`` apart), so large and small objects each keep
    their count per area. Shape: -> (len(groups),) int64."""
    from neuraltex.texton_kinds import texton_area

    area = texton_area(textons)[0, rows].detach().cpu().double().numpy()  # (E,)
    total = np.array([area[g].sum() for g in groups]).clip(1e-12)
    bins = np.floor(np.log(total) / math.log(size_ratio)).astype(np.int64)
    return np.unique(bins, return_inverse=True)[1].reshape(-1)
