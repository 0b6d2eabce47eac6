"""The output domain as a shape samples can be pulled back into (seed 001 eqs. 13, 15).

The domain is given as a predicate ``inside`` (N, 2) -> (N,) bool (the output box, and the
filled shapes of ``--domain SHAPE.svg``). Eq. 15's domain term needs, for a sample outside,
the shortest vector to the domain's border; a predicate alone cannot give it, so the box is
rasterized once per level on a grid finer than the sampling distance, and the inside grid
points with an outside neighbour stand for the border. The nearest of them is where an
outside sample is pulled (``Domain.project``) and how far a sample lies from the border
(``Domain.depth``, used by scripts/eval_curve_domain.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from scipy.spatial import cKDTree

Inside = Callable[[torch.Tensor], torch.Tensor]


def deep_inside(pos: torch.Tensor, inside: Inside, margin: float) -> np.ndarray:
    """Positions at least ``margin`` inside the domain along both axes (the four offsets by
    ``margin`` are inside). Shape: (N, 2) -> (N,) bool."""
    ok = torch.ones(len(pos), dtype=torch.bool)
    for d in ((margin, 0.0), (-margin, 0.0), (0.0, margin), (0.0, -margin)):
        ok &= inside(pos + torch.tensor(d, dtype=pos.dtype))
    return ok.numpy()


@dataclass
class Domain:
    inside: Inside
    rim: np.ndarray  # (B, 2) inside grid points next to the outside: the border
    tree: cKDTree  # over ``rim``

    @classmethod
    def of(cls, inside: Inside, box, step: float) -> Domain:
        """``inside`` rasterized over ``box`` (x0, y0, x1, y1) every ``step``; the box's own
        edge counts as border (outside the box is outside the domain)."""
        x0, y0, x1, y1 = box
        xs = np.linspace(x0, x1, max(int(np.ceil((x1 - x0) / step)) + 1, 2))
        ys = np.linspace(y0, y1, max(int(np.ceil((y1 - y0) / step)) + 1, 2))
        gx, gy = np.meshgrid(xs, ys)  # (H, W)
        pts = np.stack([gx.ravel(), gy.ravel()], 1)
        ok = inside(torch.from_numpy(pts)).numpy().reshape(gx.shape)
        pad = np.pad(ok, 1, constant_values=False)
        inner = pad[:-2, 1:-1] & pad[2:, 1:-1] & pad[1:-1, :-2] & pad[1:-1, 2:]
        rim = pts[(ok & ~inner).ravel()]
        if len(rim) == 0:  # nothing of the box is inside: nowhere to pull to
            rim = pts[:1]
        return cls(inside, rim, cKDTree(rim))

    def project(self, pos: torch.Tensor) -> torch.Tensor:
        """Nearest border point of each position. Shape: (N, 2) -> (N, 2)."""
        if len(pos) == 0:
            return pos.clone()
        idx = self.tree.query(pos.numpy())[1]
        return torch.from_numpy(self.rim[idx]).to(pos.dtype)

    def depth(self, pos: torch.Tensor) -> np.ndarray:
        """Distance to the border, negative outside. Shape: (N, 2) -> (N,)."""
        if len(pos) == 0:
            return np.zeros(0)
        dist = self.tree.query(pos.numpy())[0]
        return np.where(self.inside(pos).numpy(), dist, -dist)
