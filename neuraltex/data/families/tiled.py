"""Plane-filling families: stones with mortar, bricks, hexagonal tiles, touching pebbles.

Every cell is one texton. Mortar is background (id 0) and anti-aliased from the
distance to the cell boundary; without mortar ("pebbles") neighbours touch and are
told apart only by subtle colour and edge shading.
"""

from __future__ import annotations

import numpy as np

from neuraltex.data.families.common import (
    coords,
    inner_fields,
    lighting,
    noisy_background,
    sensor_noise,
    uniform,
)
from neuraltex.data.palette import background_color, near, palette
from neuraltex.data.tiling import bricks as brick_cells
from neuraltex.data.tiling import lattice_points, voronoi


def _fill(rng, h, w, index, dist, colors, mortar, mortar_color, edge_dark, edge_w,
          noise_amp, bg_noise=0.04):
    """Colour cells by index, darken towards their edges, put mortar in between."""
    s = min(h, w)
    tile = colors[index]  # (H, W, 3)
    tile = tile * (1.0 - edge_dark * np.exp(-dist / edge_w))[..., None]
    if noise_amp > 0:
        tile = tile + noise_amp * inner_fields(rng, h, w, uniform(rng, 15, 30))["noise"][..., None]
    if mortar > 0:
        alpha = np.clip((dist - mortar) * s + 0.5, 0.0, 1.0)[..., None]
        bg = noisy_background(rng, h, w, mortar_color, bg_noise, 20.0)
        image = bg * (1.0 - alpha) + tile * alpha
        ids = np.where(alpha[..., 0] >= 0.5, index + 1, 0)
    else:
        image, ids = tile, index + 1
    return image.astype(np.float32), ids.astype(np.int64)


def _cell_colors(rng, n_cells, n_colors, spread, value=(0.35, 0.95)):
    pal = palette(rng, n_colors, value=value)
    pick = rng.integers(n_colors, size=n_cells)
    return np.clip(pal[pick] + rng.normal(0, spread, (n_cells, 3)), 0, 1).astype(np.float32)


def stones(rng, h, w):
    """Irregular Voronoi stones separated by mortar lines."""
    x, y, extent = coords(h, w)
    cell, jitter = uniform(rng, 0.12, 0.22), uniform(rng, 0.5, 0.9)
    mortar = uniform(rng, 0.006, 0.014)
    pts, dx, dy = lattice_points(rng, extent, cell, jitter)
    index, dist = voronoi(x, y, pts, dx, dy)
    colors = _cell_colors(rng, len(pts.reshape(-1, 2)), int(rng.integers(1, 4)), 0.06)
    image, ids = _fill(rng, h, w, index, dist, colors, mortar, background_color(rng),
                       uniform(rng, 0.1, 0.3), 0.02, uniform(rng, 0.0, 0.04))
    return sensor_noise(rng, image, 0.005), ids, dict(cell=cell, jitter=jitter, mortar=mortar)


def bricks(rng, h, w):
    """Running-bond bricks with mortar."""
    x, y, extent = coords(h, w)
    bh = uniform(rng, 0.07, 0.14)
    bw, mortar = bh * uniform(rng, 1.8, 3.2), uniform(rng, 0.005, 0.012)
    index, dist, n_cells = brick_cells(rng, x, y, extent, bw, bh)
    colors = _cell_colors(rng, n_cells, int(rng.integers(1, 3)), 0.07, value=(0.35, 0.8))
    image, ids = _fill(rng, h, w, index, dist, colors, mortar, background_color(rng),
                       uniform(rng, 0.05, 0.2), 0.015, uniform(rng, 0.0, 0.04))
    return sensor_noise(rng, image, 0.005), ids, dict(brick_w=bw, brick_h=bh, mortar=mortar)


def hex_tiles(rng, h, w):
    """Regular hexagonal tiles with grout."""
    x, y, extent = coords(h, w)
    cell, mortar = uniform(rng, 0.1, 0.18), uniform(rng, 0.006, 0.014)
    pts, dx, dy = lattice_points(rng, extent, cell, 0.0, hexagonal=True)
    index, dist = voronoi(x, y, pts, dx, dy, hexagonal=True)
    colors = _cell_colors(rng, len(pts.reshape(-1, 2)), int(rng.integers(1, 4)), 0.03)
    image, ids = _fill(rng, h, w, index, dist, colors, mortar, background_color(rng),
                       uniform(rng, 0.0, 0.15), 0.02, 0.0)
    return sensor_noise(rng, image, 0.005), ids, dict(cell=cell, mortar=mortar)


def pebbles(rng, h, w):
    """HARD: touching pebbles, no mortar, one colour family, textured, lit from one side."""
    x, y, extent = coords(h, w)
    cell, jitter = uniform(rng, 0.12, 0.22), uniform(rng, 0.6, 0.9)
    pts, dx, dy = lattice_points(rng, extent, cell, jitter)
    index, dist = voronoi(x, y, pts, dx, dy)
    base = palette(rng, 1, value=(0.4, 0.8))[0]
    colors = near(rng, base, uniform(rng, 0.02, 0.05), len(pts.reshape(-1, 2)))
    image, ids = _fill(rng, h, w, index, dist, colors, 0.0, base, uniform(rng, 0.15, 0.3),
                       uniform(rng, 0.01, 0.02), uniform(rng, 0.04, 0.08))
    image = lighting(rng, image, uniform(rng, 0.2, 0.4))
    return sensor_noise(rng, image, 0.015), ids, dict(cell=cell, jitter=jitter)
