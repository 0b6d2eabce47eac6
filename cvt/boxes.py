"""Pairwise measures of axis-aligned boxes (x0, y0, x1, y1), the elements' bounding boxes.

One (A, B) array per pair measure, built axis by axis in place: the same floats as clipping an
(A, B, 2) stack of overlaps and taking its product, in a quarter of the time (these tables are
N x N over the placed copies of an output: the density repair builds several per pass).
"""

from __future__ import annotations

import numpy as np


def box_areas(b: np.ndarray) -> np.ndarray:
    """Shape: (B, 4) -> (B,)."""
    return (b[:, 2:] - b[:, :2]).prod(-1)


def box_intersection(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection areas. Shape: (A, 4), (B, 4) -> (A, B)."""
    ix = np.minimum.outer(a[:, 2], b[:, 2])
    ix -= np.maximum.outer(a[:, 0], b[:, 0])
    np.maximum(ix, 0, out=ix)
    iy = np.minimum.outer(a[:, 3], b[:, 3])
    iy -= np.maximum.outer(a[:, 1], b[:, 1])
    np.maximum(iy, 0, out=iy)
    ix *= iy
    return ix


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection over union. Shape: (A, 4), (B, 4) -> (A, B)."""
    inter = box_intersection(a, b)
    return inter / np.maximum(box_areas(a)[:, None] + box_areas(b)[None, :] - inter, 1e-12)


def box_touch(a: np.ndarray, b: np.ndarray, share: float) -> np.ndarray:
    """Boxes that share at least ``share`` of the smaller one's area.
    Shape: (A, 4), (B, 4) -> (A, B) bool."""
    return box_intersection(a, b) >= share * np.minimum.outer(box_areas(a), box_areas(b))
