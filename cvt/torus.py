"""The periodic canvas of a tileable output (``--tileable``): a torus.

Sample positions are kept unwrapped (an element's samples stay together when it drifts over
the seam); every offset between two samples is taken by the minimum-image convention, so a
sample near the right edge has neighbours across the left edge, and searches, assignment,
clustering and depth all see the pattern as it will be tiled. :meth:`Torus.gather` moves
each cluster, whole, back onto the canvas and puts its samples next to each other.
Works on torch tensors and numpy arrays alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch


@dataclass(frozen=True)
class Torus:
    origin: tuple[float, float]  # (x0, y0) of the canvas
    period: tuple[float, float]  # (width, height)

    @staticmethod
    def of(box) -> Torus:
        """The torus of the canvas ``box`` = (x0, y0, x1, y1)."""
        x0, y0, x1, y1 = box
        return Torus((float(x0), float(y0)), (float(x1 - x0), float(y1 - y0)))

    def _p(self, like):
        if isinstance(like, torch.Tensor):
            return like.new_tensor(self.period)
        return np.asarray(self.period, dtype=float)

    def diff(self, d):
        """Minimum-image offsets. Shape: (..., 2) -> (..., 2)."""
        p = self._p(d)
        r = torch.round(d / p) if isinstance(d, torch.Tensor) else np.round(d / p)
        return d - p * r

    def wrap(self, pos):
        """Positions moved by whole periods onto the canvas. Shape: (..., 2)."""
        p = self._p(pos)
        o = pos.new_tensor(self.origin) if isinstance(pos, torch.Tensor) else np.asarray(
            self.origin, dtype=float)
        return o + (pos - o) % p

    def cdist(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        """Distances on the torus. Shape: (A, 2), (B, 2) -> (A, B)."""
        return self.diff(a[:, None] - b[None]).norm(dim=-1)

    def gather(self, pos: torch.Tensor, cluster: torch.Tensor) -> torch.Tensor:
        """Each cluster's first sample wrapped onto the canvas, its other samples at their
        minimum image from it. Shape: pos (N, 2), cluster (N,) -> (N, 2)."""
        if len(pos) == 0:
            return pos
        _, inv = torch.unique(cluster, return_inverse=True)
        first = torch.full((int(inv.max()) + 1,), len(pos), dtype=torch.long)
        first = first.scatter_reduce(0, inv, torch.arange(len(pos)), reduce="amin")
        anchor = pos[first[inv]]  # (N, 2)
        return self.wrap(anchor) + self.diff(pos - anchor)


def offsets(d, torus: Torus | None):
    """``d`` (differences of positions), by the minimum image on a torus. Shape: (..., 2)."""
    return d if torus is None else torus.diff(d)


def periodic_max(f, a: np.ndarray, b: np.ndarray, torus: Torus | None) -> np.ndarray:
    """``f(a, b)`` of two box arrays, on a torus the largest over the 9 periodic images of
    ``b`` (a box meets its neighbour across the seam). Shape: (A, 4), (B, 4) -> (A, B)."""
    if torus is None:
        return f(a, b)
    w, h = torus.period
    return np.max([f(a, b + np.array([i * w, j * h, i * w, j * h]))
                   for i in (-1, 0, 1) for j in (-1, 0, 1)], axis=0)


def images(boxes: np.ndarray, torus: Torus | None) -> np.ndarray:
    """The boxes and, on a torus, their 8 periodic images. Shape: (P, 4) -> (9P, 4)."""
    if torus is None:
        return boxes
    w, h = torus.period
    return np.concatenate([boxes + np.array([i * w, j * h, i * w, j * h])
                           for i in (0, -1, 1) for j in (0, -1, 1)])
