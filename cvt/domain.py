"""Shaped output (``--domain SHAPE.svg``): a closed region to fill instead of the rectangle.

The region is the even-odd union of the closed filled rings of the SVG's shapes (holes work),
fitted into the output canvas (scaled uniformly and centred). The curve synthesis can reuse it:

    dom = Domain.from_svg("star.svg").fitted((0, 0, 400, 300))
    dom.contains(xy)  # (N, 2) -> (N,) bool
    dom.bounds        # (x0, y0, x1, y1)
    dom.area
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neuraltex.errors import InputError


@dataclass(frozen=True)
class Domain:
    rings: tuple[np.ndarray, ...]  # each (P, 2), closed implicitly

    @staticmethod
    def from_svg(path, limits=None) -> Domain:
        """The closed filled shapes of an SVG file (InputError if none, open or crossing)."""
        from cvt.limits import DEFAULT
        from cvt.svg import load_svg

        try:
            ex = load_svg(path, "shapes", limits or DEFAULT)
        except InputError as exc:
            raise InputError(f"--domain {path}: {exc}") from None
        rings = []
        for e in ex.background + ex.elements:
            for s in e.shapes:
                for ring, closed in zip(s.rings, s.closed, strict=True):
                    if not closed and not np.allclose(ring[0], ring[-1]):
                        raise InputError(f"--domain {path}: a shape is not closed")
                    if len(ring) >= 3:
                        rings.append(ring)
        dom = Domain(tuple(rings))
        if not rings or dom.area <= 0:
            raise InputError(f"--domain {path}: no closed shape with an area")
        if any(_self_intersects(r) for r in rings):
            raise InputError(f"--domain {path}: a shape's outline crosses itself")
        return dom

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        pts = np.concatenate(self.rings)
        return (*pts.min(0), *pts.max(0))

    @property
    def area(self) -> float:
        """Area of the region (sampled on a 256 x 256 grid over the bounds)."""
        x0, y0, x1, y1 = self.bounds
        if x1 <= x0 or y1 <= y0:
            return 0.0
        t = (np.arange(256) + 0.5) / 256
        u, v = np.meshgrid(x0 + t * (x1 - x0), y0 + t * (y1 - y0))
        return float(self.contains(np.c_[u.ravel(), v.ravel()]).mean() * (x1 - x0) * (y1 - y0))

    def contains(self, xy: np.ndarray) -> np.ndarray:
        """Even-odd inside test. Shape: (N, 2) -> (N,) bool."""
        xy = np.asarray(xy, dtype=float)
        inside = np.zeros(len(xy), bool)
        for r in self.rings:
            a, b = r, np.roll(r, -1, axis=0)  # edges a -> b, (P, 2)
            x, y = xy[:, None, 0], xy[:, None, 1]  # (N, 1)
            straddle = (a[None, :, 1] > y) != (b[None, :, 1] > y)  # (N, P)
            dy = np.where(b[:, 1] == a[:, 1], 1e-300, b[:, 1] - a[:, 1])
            xc = a[None, :, 0] + (y - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / dy
            inside ^= (straddle & (x < xc)).sum(1) % 2 == 1
        return inside

    def fitted(self, box) -> Domain:
        """Scaled uniformly and centred into ``box`` (x0, y0, x1, y1)."""
        x0, y0, x1, y1 = self.bounds
        s = min((box[2] - box[0]) / (x1 - x0), (box[3] - box[1]) / (y1 - y0))
        off = np.array([(box[0] + box[2]) / 2, (box[1] + box[3]) / 2])
        mid = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        return Domain(tuple((r - mid) * s + off for r in self.rings))

    def svg_path(self) -> str:
        """The region as an SVG path ``d`` (for clipping the output)."""
        return " ".join("M" + " L".join(f"{x:.6g},{y:.6g}" for x, y in r) + " Z"
                        for r in self.rings)


def _self_intersects(ring: np.ndarray) -> bool:
    """Whether two non-adjacent edges of a closed ring cross. (P, 2) -> bool."""
    p = ring[np.r_[True, np.any(np.diff(ring, axis=0) != 0, axis=1)]]  # no repeated points
    n = len(p)
    if n < 4:
        return False
    a, b = p, np.roll(p, -1, axis=0)  # (n, 2) edges

    def orient(p0, p1, q):  # sign of the cross product (p1 - p0) x (q - p0), broadcast
        return np.sign((p1[..., 0] - p0[..., 0]) * (q[..., 1] - p0[..., 1])
                       - (p1[..., 1] - p0[..., 1]) * (q[..., 0] - p0[..., 0]))

    A, B = a[:, None], b[:, None]  # (n, 1, 2)
    C, D = a[None], b[None]  # (1, n, 2)
    cross = ((orient(A, B, C) * orient(A, B, D) < 0) & (orient(C, D, A) * orient(C, D, B) < 0))
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    adjacent = (np.abs(i - j) <= 1) | (np.abs(i - j) == n - 1)
    return bool((cross & ~adjacent).any())
