"""Plane-filling tilings: Voronoi cells (stones, pebbles, hexagons) and bricks.

Each tiling returns, per pixel, the index of its cell and the distance to the
cell's boundary in normalized units. Everything is vectorized over the image.
"""

from __future__ import annotations

import numpy as np


def lattice_points(rng: np.random.Generator, extent: tuple[float, float], cell: float,
                   jitter: float, hexagonal: bool = False) -> tuple[np.ndarray, float, float]:
    """Jittered points, one per cell of a square or hexagonal lattice, with a 2-cell margin.

    Returns points (GY, GX, 2) in normalized units and the lattice steps (dx, dy).
    Row r of a hexagonal lattice is shifted by dx / 2 when r is odd.
    """
    dx = cell
    dy = cell * np.sqrt(3.0) / 2.0 if hexagonal else cell
    gx = int(np.ceil(extent[0] / dx)) + 4
    gy = int(np.ceil(extent[1] / dy)) + 4
    cols, rows = np.meshgrid(np.arange(gx) - 2, np.arange(gy) - 2)
    shift = 0.5 * (rows % 2) if hexagonal else 0.0
    px = (cols + 0.5 + shift) * dx
    py = (rows + 0.5) * dy
    jit = rng.uniform(-0.5, 0.5, size=(gy, gx, 2)) * jitter
    pts = np.stack([px + jit[..., 0] * dx, py + jit[..., 1] * dy], -1).astype(np.float32)
    return pts, dx, dy


def voronoi(x: np.ndarray, y: np.ndarray, pts: np.ndarray, dx: float, dy: float,
            hexagonal: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Nearest lattice point and distance to the Voronoi boundary, from the 3x3 neighbourhood.

    Shape: x (1, W), y (H, 1), pts (GY, GX, 2) -> cell index (H, W) int64 into the
    flattened lattice, boundary distance (H, W) float32 (>= 0). With jitter <= 0.9 cell
    the 3x3 neighbourhood almost always holds the true nearest point; where it does not,
    the partition is still a valid (slightly non-convex) tiling.
    """
    gy, gx = pts.shape[:2]
    X, Y = np.broadcast_arrays(x, y)
    row0 = np.floor(Y / dy).astype(np.int64) + 2
    shift = 0.5 * ((row0 - 2) % 2) * dx if hexagonal else 0.0
    col0 = np.floor((X - shift) / dx).astype(np.int64) + 2
    flat_x, flat_y = pts[..., 0].ravel(), pts[..., 1].ravel()
    cands = []
    best_d2 = np.full(X.shape, np.inf, np.float32)
    index = np.zeros(X.shape, np.int64)
    for di in (-1, 0, 1):
        r = np.clip(row0 + di, 0, gy - 1) * gx
        for dj in (-1, 0, 1):
            idx = r + np.clip(col0 + dj, 0, gx - 1)  # (H, W) flat lattice index
            qx, qy = flat_x.take(idx), flat_y.take(idx)
            d2 = (qx - X) ** 2 + (qy - Y) ** 2
            cands.append((idx, qx, qy))
            closer = d2 < best_d2
            np.copyto(best_d2, d2, where=closer)
            np.copyto(index, idx, where=closer)
    p1x, p1y = flat_x.take(index), flat_y.take(index)
    # Distance to the bisector between the nearest point p1 and every other candidate q.
    dist = np.full(X.shape, np.inf, np.float32)
    for idx, qx, qy in cands:
        ex, ey = qx - p1x, qy - p1y
        norm = np.sqrt(ex * ex + ey * ey)
        d = ((0.5 * (qx + p1x) - X) * ex + (0.5 * (qy + p1y) - Y) * ey) / np.maximum(norm, 1e-9)
        dist = np.minimum(dist, np.where(idx == index, np.inf, d))
    return index, dist.astype(np.float32)


def bricks(rng: np.random.Generator, x: np.ndarray, y: np.ndarray, extent: tuple[float, float],
           width: float, height: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Running-bond bricks, each row shifted by a random offset.

    Returns cell index (H, W), boundary distance (H, W) as :func:`voronoi`, and the
    number of cells (fixed by the extent, not the resolution).
    """
    n_rows = int(np.ceil(extent[1] / height)) + 2
    n_cols = int(np.ceil(extent[0] / width)) + 3
    offsets = (0.5 * np.arange(n_rows) % 1.0 + rng.uniform(-0.15, 0.15, n_rows)) * width
    X, Y = np.broadcast_arrays(x, y)
    row = np.floor(Y / height).astype(np.int64)
    xs = X + offsets[np.clip(row, 0, n_rows - 1)].astype(np.float32)
    col = np.floor(xs / width).astype(np.int64)
    fx, fy = xs - col * width, Y - row * height
    dist = np.minimum(np.minimum(fx, width - fx), np.minimum(fy, height - fy))
    return row * n_cols + col, dist.astype(np.float32), n_rows * n_cols
