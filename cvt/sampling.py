"""Clustered samples: Poisson-disk samples per element, held in torch tensors (seed 000 sec. 4).

Filled elements are sampled over their interior, stroke-only parts along their outline. Each
sample records position, cluster id, existence, z-index (document order) and a shape-context
feature computed within its cluster.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch

from cvt.shape_context import shape_contexts
from cvt.svg import Element, Exemplar, Shape

DEFAULT_DELTAS = (1 / 20, 1 / 30, 1 / 40)  # sampling distance / exemplar size (sec. 7.3)
DEFAULT_RADII = (1 / 6, 1 / 8, 1 / 12)  # neighborhood radius / exemplar size (sec. 7.3)
MAX_ALONG = 200_000  # points along one outline (a longer one is walked in coarser steps)
MAX_GRID = 1_000_000  # fill-grid points of one element (a larger grid is cut to the region)
CHUNK = 1 << 22  # points x edges per block of the fill test (~100 MB of temporaries)


@dataclass(frozen=True)
class Level:
    delta: float  # Poisson-disk sampling distance, user units
    radius: float  # neighborhood radius, user units


def hierarchy(size: float, levels: int = 3, deltas=DEFAULT_DELTAS,
              radii=DEFAULT_RADII) -> list[Level]:
    """Coarse-to-fine levels; with fewer levels than fractions, keep the finest ones."""
    if not 1 <= levels <= len(deltas):
        raise ValueError(f"levels must be in 1..{len(deltas)}")
    pairs = list(zip(deltas, radii, strict=True))[len(deltas) - levels :]
    return [Level(d * size, r * size) for d, r in pairs]


@dataclass
class Samples:
    """A clustered sample set. All tensors share the first dimension N."""

    pos: torch.Tensor  # (N, 2) float
    cluster: torch.Tensor  # (N,) long, cluster id
    z: torch.Tensor  # (N,) long, z-index (document order of the source element)
    exist: torch.Tensor  # (N,) float, existence confidence xi
    feat: torch.Tensor  # (N, 60) shape context within the cluster
    element: torch.Tensor  # (N,) long, source element index (input) / -1 unknown
    source: torch.Tensor  # (N,) long, input sample this one was copied from / -1

    def __len__(self) -> int:
        return self.pos.shape[0]

    def select(self, idx: torch.Tensor) -> Samples:
        return Samples(*(getattr(self, f)[idx] for f in _FIELDS))

    def cat(self, other: Samples) -> Samples:
        return Samples(*(torch.cat([getattr(self, f), getattr(other, f)]) for f in _FIELDS))

    def with_(self, **kw) -> Samples:
        return replace(self, **kw)

    @staticmethod
    def concat(parts: list[Samples]) -> Samples:
        return Samples(*(torch.cat([getattr(p, f) for p in parts]) for f in _FIELDS))


_FIELDS = ("pos", "cluster", "z", "exist", "feat", "element", "source")


def _inside(points: np.ndarray, shape: Shape) -> np.ndarray:
    """Fill test of points against a shape's closed rings (nonzero or even-odd rule).

    Shape: points (M, 2) -> (M,) bool.
    """
    wind = np.zeros(len(points), dtype=np.int64)
    for ring in shape.rings:
        if len(ring) < 3:
            continue
        a, b = ring, np.roll(ring, -1, axis=0)  # (E, 2) edges a -> b, implicitly closed
        step = max(1, CHUNK // len(ring))  # points per block: memory stays bounded
        for i in range(0, len(points), step):
            wind[i : i + step] += _winding(points[i : i + step], a, b)
    return (wind % 2 == 1) if shape.evenodd else (wind != 0)


def _winding(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Winding number of points around the edges a -> b. Shape: (M, 2), (E, 2) x 2 -> (M,)."""
    x, y = points[:, :1], points[:, 1:]
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    left = (bx - ax) * (y - ay) - (x - ax) * (by - ay)  # (M, E) > 0: point left of edge
    up = (ay <= y) & (by > y) & (left > 0)
    down = (ay > y) & (by <= y) & (left < 0)
    return up.sum(1) - down.sum(1)


def _along(ring: np.ndarray, closed: bool, step: float) -> np.ndarray:
    """Points every ``step`` along a polyline. Shape: (P, 2) -> (Q, 2)."""
    pts = np.vstack([ring, ring[:1]]) if closed else ring
    if len(pts) < 2:
        return pts
    seg = np.diff(pts, axis=0)
    cum = np.r_[0, np.cumsum(np.linalg.norm(seg, axis=1))]
    step = max(step, cum[-1] / MAX_ALONG)
    t = np.arange(0, cum[-1] + 1e-9, step) if cum[-1] > 0 else np.zeros(1)
    return np.stack([np.interp(t, cum, pts[:, 0]), np.interp(t, cum, pts[:, 1])], 1)


def element_candidates(element: Element, delta: float, rng: np.random.Generator,
                       region=None) -> np.ndarray:
    """Dense candidate points on an element: jittered grid in fills, points along strokes.
    The grid covers the element's box; when that takes more than MAX_GRID points it is cut to
    ``region`` (x0, y0, x1, y1): the part of a huge element far off the canvas gets no samples.

    Shape: -> (M, 2).
    """
    box = element.bbox
    extent = max(min(box[2] - box[0], box[3] - box[1]), 1e-9)
    step = min(delta / 3, extent / 4)
    lo, hi = box[:2], box[2:]
    if region is not None and np.prod((hi - lo) / step) > MAX_GRID:
        lo, hi = np.maximum(lo, region[:2]), np.minimum(hi, region[2:])
        step = max(step, delta / 3 * 1e-3)  # a thin sliver of a huge element: a finite grid
    out = []
    gx = np.arange(lo[0] + step / 2, hi[0], step)
    gy = np.arange(lo[1] + step / 2, hi[1], step)
    grid = np.stack(np.meshgrid(gx, gy), -1).reshape(-1, 2)
    grid = grid + rng.uniform(-step / 3, step / 3, grid.shape)
    for shape in element.shapes:
        if shape.filled:
            out.append(grid[_inside(grid, shape)])
        if shape.stroke_width > 0 or not shape.filled:
            for ring, closed in zip(shape.rings, shape.closed, strict=True):
                out.append(_along(ring, closed, step))
    cand = np.concatenate(out) if out else np.zeros((0, 2))
    if len(cand) == 0:  # degenerate: a single point at the box center
        cand = ((box[:2] + box[2:]) / 2)[None]
    return cand


def poisson_disk(cand: np.ndarray, delta: float, rng: np.random.Generator) -> np.ndarray:
    """Maximal dart throwing over candidates in random order: kept points are >= delta apart.

    Shape: (M, 2) -> (K, 2), K >= 1 when M >= 1.
    """
    cell = delta / np.sqrt(2)  # at most one kept point per cell
    grid: dict[tuple[int, int], np.ndarray] = {}
    kept = []
    for p in cand[rng.permutation(len(cand))]:
        ci, cj = int(np.floor(p[0] / cell)), int(np.floor(p[1] / cell))
        ok = True
        for di in range(-2, 3):
            for dj in range(-2, 3):
                q = grid.get((ci + di, cj + dj))
                if q is not None and (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2 < delta * delta:
                    ok = False
                    break
            if not ok:
                break
        if ok:
            grid[(ci, cj)] = p
            kept.append(p)
    return np.array(kept).reshape(-1, 2)


def sample_exemplar(exemplar: Exemplar, delta: float, seed: int = 0,
                    dtype: torch.dtype = torch.float32) -> Samples:
    """Poisson-disk samples of every element; cluster id = z = element index."""
    rng = np.random.default_rng(seed)
    x, y, w, h = exemplar.viewbox
    region = np.array([x - w, y - h, x + 2 * w, y + 2 * h])  # the canvas and one more around
    pos, elem = [], []
    for e in exemplar.elements:
        pts = poisson_disk(element_candidates(e, delta, rng, region), delta, rng)
        pos.append(pts)
        elem.append(np.full(len(pts), e.index))
    p = torch.as_tensor(np.concatenate(pos), dtype=dtype)  # (N, 2)
    el = torch.as_tensor(np.concatenate(elem), dtype=torch.long)  # (N,)
    n = len(el)
    return Samples(p, el.clone(), el.clone(), torch.ones(n, dtype=dtype), shape_contexts(p, el),
                   el.clone(), torch.arange(n))
