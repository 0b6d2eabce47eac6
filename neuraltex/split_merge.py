"""Joining the pieces of elements that a finer segmentation split.

Seen zoomed in (:mod:`neuraltex.tiled_encode`), E_s cuts many elements into pieces of about
its anchor cell: a star into its arms, a leaf or a stroke into three or four. The
whole-picture run, coarser, keeps them whole, but on a dense picture it lumps neighbours
into blobs. Two adjacent fine segments are one element when

* one coarse segment holds most of each (``share``): the coarse run saw them as one, and
* no image edge separates them: the median Sobel magnitude of the grey picture over the pixel
  pairs where they touch is below ``edge`` (the median, as the seam's ends meet the element's
  outline).

Neighbouring elements in one coarse blob stay apart, since an edge (mortar, an outline, a
shadow) runs between them; pieces of one element have none. Both thresholds were picked on
the validation split (MODEL.md, "Patch-wise encoding").
"""

from __future__ import annotations

import numpy as np

from neuraltex.tiled_segments import consecutive

EDGE = 0.03  # median Sobel magnitude (grey in [0, 1]) along the seam, below which it is no edge
SHARE = 0.5  # share of a fine segment's pixels that its coarse segment must hold


def merge_split(fine: np.ndarray, coarse: np.ndarray, grey: np.ndarray,
                edge: float = EDGE, share: float = SHARE) -> np.ndarray:
    """Labels (H, W) int64 of ``fine`` (H, W) int (0 = no segment) with its split elements
    joined (module doc), given the ``coarse`` labels (H, W) int (0 = no segment; never a
    home) of the same picture and the picture ``grey`` (H, W) in [0, 1]. Segment 0 is never
    joined; the other labels come out consecutive from 1."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from skimage.filters import sobel

    if not fine.shape == coarse.shape == grey.shape:
        raise ValueError(f"fine {fine.shape}, coarse {coarse.shape} and grey {grey.shape} "
                         "must have one shape")
    ids, fine = np.unique(fine, return_inverse=True)
    fine = fine.reshape(coarse.shape)
    if ids[0] != 0:  # no "no segment" pixel: keep index 0 free for it
        fine += 1
    n = int(fine.max()) + 1
    coarse_ids, coarse = np.unique(coarse, return_inverse=True)
    coarse = coarse.reshape(fine.shape)
    # Each fine segment's home: the coarse segment holding most of it, if it holds `share`.
    m = int(coarse.max()) + 1
    table = np.bincount((fine * m + coarse).ravel(), minlength=n * m).reshape(n, m)
    home = table.argmax(1)
    size = table.sum(1)
    held = table[np.arange(n), home] >= share * np.maximum(size, 1)
    home = np.where(held & ((home > 0) | (coarse_ids[0] != 0)), home, -1)  # not "no segment"
    # Median edge strength over the pixel pairs along each seam between two fine segments (the
    # median: where a seam ends it meets the element's outline, which is no edge between them).
    strength = sobel(grey.astype(np.float64))
    a = np.concatenate([fine[:, :-1].ravel(), fine[:-1].ravel()])
    b = np.concatenate([fine[:, 1:].ravel(), fine[1:].ravel()])
    e = np.concatenate([(strength[:, :-1] + strength[:, 1:]).ravel(),
                        (strength[:-1] + strength[1:]).ravel()]) / 2
    seam = (a != b) & (a > 0) & (b > 0)
    lo, hi = np.minimum(a[seam], b[seam]), np.maximum(a[seam], b[seam])
    pair, inverse = np.unique(lo * n + hi, return_inverse=True)
    order = np.lexsort((e[seam], inverse))  # by seam, then by strength
    length = np.bincount(inverse)
    median = e[seam][order][np.cumsum(length) - length + (length - 1) // 2]
    lo, hi = pair // n, pair % n
    join = (home[lo] >= 0) & (home[lo] == home[hi]) & (median < edge)
    graph = coo_matrix((np.ones(int(join.sum())), (lo[join], hi[join])), shape=(n, n))
    _, root = connected_components(graph, directed=False)
    return consecutive(np.where(fine == 0, 0, root[fine] + 1))  # 0 is never in a pair
