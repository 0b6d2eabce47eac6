"""One labelling of a picture from the labels of its overlapping tiles (patch-wise
segmentation).

E_s sees at most ``num_queries`` elements per call, at its training resolution: a photograph
with many elements (e.g. 71 bricks in data/real_textures/brick.png) is squeezed into one
128 px call and comes out as blobs, where each 128 px quarter alone is segmented brick by
brick (MODEL.md, "Textons per visible element"; ``scripts/probe_bricks.py``).
:mod:`neuraltex.tiled_encode` therefore labels overlapping tiles of the picture; here their
labels become one. Every tile owns a core (the tiles' cores partition the picture), and a
tile's segment is kept when its centre lies in that tile's core, so an element cut by a tile
border is kept from the tile that holds most of it. Each pixel takes the kept segment that
claims it in its own core's tile, else in another tile that covers it; a pixel no kept
segment claims (about 2 % of them, where a tile's segmentation of an element differs from its
keeper's) goes to the nearest claimed segment (with none kept anywhere, the core tiles' own
segments stand). A segment larger than the overlap (a background) is kept by every tile it
spans; those pieces are joined where they claim the same pixels in the tiles' overlap.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

SAME = 0.5  # IoU where two tiles overlap above which their kept segments are one
DENSE = 50  # segments of E_s's whole-picture run from which tiles pay (validation split:
            # MODEL.md, "Patch-wise encoding")
TILING = ("auto", "on", "off")  # how neuraltex.tiled_encode.encode_image encodes a picture


def tile_origins(size: int, tile: int, overlap: int) -> list[int]:
    """Starts of the tiles along one side of ``size`` px: ``tile - overlap`` apart, the last
    flush with the end (one tile when ``size <= tile``)."""
    if not 0 <= overlap < tile:
        raise ValueError(f"overlap must be in [0, tile), got {overlap} for tile {tile}")
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


def merge_tiles(parts: dict[tuple[int, int], np.ndarray], shape: tuple[int, int],
                ys: list[int], xs: list[int]) -> np.ndarray:
    """Labels (H, W) int64 (0 = no segment, 1.. segments) of a picture of ``shape`` from the
    labels of its tiles: ``parts[i, j]`` (h, w) int (0 = no segment) of the tile at
    (``ys[i]``, ``xs[j]``) (:func:`tile_origins`; module doc)."""
    H, W = shape
    tile_h, tile_w = parts[0, 0].shape
    core_y, core_x = _cores(ys, H, tile_h), _cores(xs, W, tile_w)
    claims = {}  # (i, j) -> (h, w) the kept segment claiming each pixel of tile (i, j), or 0
    own = np.zeros((H, W), np.int64)  # the core tile's segment of each pixel, kept or not
    next_id = 1
    for (i, j), part in parts.items():
        y0, x0 = ys[i], xs[j]
        part = np.asarray(part, np.int64)
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
    unclaimed = (owner == 0) & (own > 0)  # in a segment, but none kept claims it
    if unclaimed.any() and (owner > 0).any():  # -> the nearest claimed segment
        from scipy.ndimage import distance_transform_edt

        _, (iy, ix) = distance_transform_edt(owner == 0, return_indices=True)
        owner = np.where(unclaimed, owner[iy, ix], owner)
    return consecutive(_same_across_tiles(claims, ys, xs, next_id)[np.where(owner > 0, owner,
                                                                          own)])


def consecutive(labels: np.ndarray) -> np.ndarray:
    """Labels (any shape, ints >= 0; 0 = no segment) renumbered 1..K in order, 0 kept."""
    _, dense = np.unique(labels, return_inverse=True)
    return dense.reshape(labels.shape) + (0 if (labels == 0).any() else 1)


def _same_across_tiles(claims: dict, ys: list[int], xs: list[int], count: int,
                       agree: float = SAME) -> np.ndarray:
    """(count,) the segment each kept segment is merged into: kept segments of two tiles that
    claim the same pixels where the tiles overlap (IoU there >= ``agree``) are one segment
    (one larger than the overlap, e.g. a background, is kept by every tile it spans)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    edges = []
    for (i, j), mine in claims.items():  # each pair of overlapping tiles once
        h, w = mine.shape
        for k in range(i, len(ys)):
            if ys[k] >= ys[i] + h:
                break
            for l in range(len(xs)):
                if (k, l) <= (i, j) or abs(xs[l] - xs[j]) >= w:
                    continue
                other = claims[k, l]
                y0, y1 = ys[k], min(ys[i] + h, ys[k] + other.shape[0])
                x0, x1 = max(xs[j], xs[l]), min(xs[j] + w, xs[l] + other.shape[1])
                if y0 >= y1 or x0 >= x1:
                    continue
                a = mine[y0 - ys[i]:y1 - ys[i], x0 - xs[j]:x1 - xs[j]].ravel()
                b = other[y0 - ys[k]:y1 - ys[k], x0 - xs[l]:x1 - xs[l]].ravel()
                both = (a > 0) & (b > 0)
                if not both.any():
                    continue
                ids_a, size_a = np.unique(a, return_counts=True)
                ids_b, size_b = np.unique(b, return_counts=True)
                pairs, shared = np.unique(np.stack([a[both], b[both]]), axis=1,
                                          return_counts=True)
                union = (size_a[np.searchsorted(ids_a, pairs[0])]
                         + size_b[np.searchsorted(ids_b, pairs[1])] - shared)
                edges.append(pairs[:, shared / union >= agree])
    if not edges:
        return np.arange(count)
    pairs = np.concatenate(edges, axis=1)
    graph = coo_matrix((np.ones(pairs.shape[1]), (pairs[0], pairs[1])), shape=(count, count))
    _, root = connected_components(graph, directed=False)
    root += 1
    root[0] = 0  # "no segment" stays 0 (it is never in a pair)
    return root
