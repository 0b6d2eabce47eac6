"""Segments of a picture from a segmenter run on overlapping tiles (patch-wise segmentation).

E_s sees at most ``num_queries`` elements per call, at its training resolution: a photograph
with many elements (e.g. 71 bricks in data/real_textures/brick.png) is squeezed into one
128 px call and comes out as blobs, where each 128 px quarter alone is segmented brick by
brick (MODEL.md, "Textons per visible element"; ``scripts/probe_bricks.py``). Here the
picture is cut into ``tile`` x ``tile`` tiles overlapping by ``overlap`` pixels; every tile
owns a core (the tiles' cores partition the picture), and a tile's segment is kept when its
centre lies in that tile's core, so an element cut by a tile border is kept from the tile
that holds most of it. Each pixel takes the kept segment that claims it in its own core's
tile, else in another tile that covers it; a pixel no kept segment claims keeps its core
tile's segment (under a label of its own).
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import pairwise

import numpy as np

Segment = Callable[[np.ndarray], np.ndarray]  # (h, w, 3) -> (h, w) int64, 0 = no segment


def tile_origins(size: int, tile: int, overlap: int) -> list[int]:
    """Starts of the tiles along one side of ``size`` px: ``tile - overlap`` apart, the last
    flush with the end (one tile when ``size <= tile``)."""
    if size <= tile:
        return [0]
    step = max(1, tile - overlap)
    starts = list(range(0, size - tile, step))
    return starts + [size - tile]


def _cores(origins: list[int], size: int, tile: int) -> list[tuple[int, int]]:
    """[start, end) of each tile's core along one side: from the middle of its overlap with
    the previous tile to the middle of its overlap with the next."""
    cuts = [0] + [(b + a + tile) // 2 for a, b in pairwise(origins)] + [size]
    return list(pairwise(cuts))


def tiled_labels(segment: Segment, image: np.ndarray, tile: int, overlap: int) -> np.ndarray:
    """Labels (H, W) int64 (0 = no segment, 1.. segments) of ``image`` (H, W, 3) from
    ``segment`` run on its overlapping tiles (module doc)."""
    if not 0 <= overlap < tile:
        raise ValueError(f"overlap must be in [0, tile), got {overlap} for tile {tile}")
    H, W = image.shape[:2]
    ys, xs = tile_origins(H, tile, overlap), tile_origins(W, tile, overlap)
    core_y, core_x = _cores(ys, H, tile), _cores(xs, W, tile)
    claims = {}  # (i, j) -> (h, w) the kept segment claiming each pixel of tile (i, j), or 0
    own = np.zeros((H, W), np.int64)  # the core tile's segment of each pixel, kept or not
    next_id = 1
    for i, y0 in enumerate(ys):
        for j, x0 in enumerate(xs):
            part = np.asarray(segment(image[y0:y0 + tile, x0:x0 + tile]), np.int64)
            h, w = part.shape
            ids, inverse = np.unique(part, return_inverse=True)
            inverse = inverse.reshape(h, w)
            rows, cols = np.mgrid[y0:y0 + h, x0:x0 + w]
            count = np.bincount(inverse.ravel(), minlength=len(ids))
            cy = np.bincount(inverse.ravel(), rows.ravel(), len(ids)) / count
            cx = np.bincount(inverse.ravel(), cols.ravel(), len(ids)) / count
            (a, b), (c, d) = core_y[i], core_x[j]
            kept = (ids != 0) & (cy >= a) & (cy < b) & (cx >= c) & (cx < d)
            gid = np.zeros(len(ids), np.int64)
            gid[ids != 0] = np.arange(next_id, next_id + int((ids != 0).sum()))
            next_id += int((ids != 0).sum())
            claims[i, j] = np.where(kept, gid, 0)[inverse]
            own[a:b, c:d] = gid[inverse[a - y0:b - y0, c - x0:d - x0]]
    owner = np.zeros((H, W), np.int64)  # the kept segment a pixel goes to, or 0
    for (i, j), claim in claims.items():  # a pixel's own core tile claims it first
        (a, b), (c, d) = core_y[i], core_x[j]
        owner[a:b, c:d] = claim[a - ys[i]:b - ys[i], c - xs[j]:d - xs[j]]
    for (i, j), claim in claims.items():  # then any other tile whose kept segment covers it
        region = owner[ys[i]:ys[i] + claim.shape[0], xs[j]:xs[j] + claim.shape[1]]
        free = region == 0
        region[free] = claim[free]
    labels = np.where(owner > 0, owner, own)
    _, dense = np.unique(labels, return_inverse=True)  # consecutive, 0 stays 0 if present
    return dense.reshape(H, W) + (0 if (labels == 0).any() else 1)
