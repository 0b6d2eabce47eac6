"""The emptiest of many candidate spots for a box (density repair, cvt.canvas), fast and exact.

A spot's rank is (total overlap area with the placed boxes, ascending; clearance to them,
descending; index): the box goes where it overlaps least, and among spots overlapping nothing
where the nearest box is farthest. Scoring every spot against every box takes (S, P, 2)
arrays (P up to 9 x 1200 boxes on a torus); instead:

1. **Screen**: only pairs whose x-intervals can meet are listed (boxes sorted by their left
   side; a box reaches at most the widest box's width to the right), and their overlap areas
   summed per spot in any order. A sum is 0 exactly when every overlap is, so the spots that
   overlap nothing are known exactly; otherwise the spots whose screened sum is within a
   rounding margin of the least are kept.
2. **Re-check**: the kept spots are scored against all boxes with the full formula
   (:func:`spot_keys`, row by row the same floats as scoring all spots at once), and ranked.

The chosen spot is the one the full scoring picks, bit for bit (tests/test_cvt_free_spot.py).
"""

from __future__ import annotations

import numpy as np

ROUNDING = 1e-9  # relative margin of the screened overlap sums (their order of summation)
CHUNK = 64  # spots scored at once by the full formula: (CHUNK, P, 2) temporaries


def spot_keys(spots: np.ndarray, half: np.ndarray, mb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total overlap area and clearance of a box of half-size ``half`` centred at each spot
    with the boxes ``mb``. Shape: spots (S, 2), half (2,), mb (P, 4) -> (S,), (S,)."""
    over = np.empty(len(spots))
    clear = np.empty(len(spots))
    c, hb = (mb[None, :, :2] + mb[None, :, 2:]) / 2, (mb[None, :, 2:] - mb[None, :, :2]) / 2
    for s in range(0, len(spots), CHUNK):
        q = spots[s : s + CHUNK, None]  # (c, 1, 2)
        gap = np.maximum(np.abs(q - c) - half - hb, 0)  # (c, P, 2)
        clear[s : s + CHUNK] = np.linalg.norm(gap, axis=2).min(1)
        over[s : s + CHUNK] = np.clip(np.minimum(q + half, mb[None, :, 2:])
                                      - np.maximum(q - half, mb[None, :, :2]), 0,
                                      None).prod(-1).sum(1)
    return over, clear


def _screened_overlaps(spots: np.ndarray, half: np.ndarray, mb: np.ndarray) -> np.ndarray:
    """Total overlap area per spot, summed over the boxes whose x-interval can meet the
    spot's (any order: equal to :func:`spot_keys`' up to rounding, 0 exactly when it is).
    Shape: spots (S, 2), half (2,), mb (P, 4) -> (S,)."""
    order = np.argsort(mb[:, 0], kind="stable")
    left = mb[order, 0]
    reach = (mb[:, 2] - mb[:, 0]).max()
    reach += ROUNDING * (reach + np.abs(mb).max())  # a box right of its left side + width
    lo = np.searchsorted(left, spots[:, 0] - half[0] - reach, "left")
    hi = np.searchsorted(left, spots[:, 0] + half[0], "right")
    n = np.maximum(hi - lo, 0)
    rows = np.repeat(np.arange(len(spots)), n)
    cols = order[np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + np.repeat(lo, n)]
    q, b = spots[rows], mb[cols]  # (pairs, 2), (pairs, 4)
    w = np.clip(np.minimum(q + half, b[:, 2:]) - np.maximum(q - half, b[:, :2]), 0, None)
    return np.bincount(rows, w[:, 0] * w[:, 1], minlength=len(spots))


def emptiest_spot(spots: np.ndarray, half: np.ndarray, mb: np.ndarray) -> int:
    """Index of the spot that ranks first by (overlap, -clearance, index) for a box of
    half-size ``half``. Shape: spots (S, 2), half (2,), mb (P, 4) with P >= 1 -> int."""
    approx = _screened_overlaps(spots, half, mb)
    least = approx.min()
    keep = np.nonzero(approx <= least + ROUNDING * least)[0]  # all spots tied with the best
    over, clear = spot_keys(spots[keep], half, mb)
    return int(keep[np.lexsort((-clear, over))[0]])
