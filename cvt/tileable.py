"""Tileable output (``--tileable``): the pattern repeats seamlessly when tiled.

The synthesis itself runs on a torus (cvt.torus: neighbourhoods, search, assignment and
clustering wrap around the canvas), and so does the canvas repair. Here each placed element is
kept once, moved by whole periods so its centre lies on the canvas; copies that meet a wrapped
neighbour more than any two exemplar elements overlap are dropped; and every element crossing
an edge is drawn again on the opposite side, so tiles join without cut or doubled motifs.
"""

from __future__ import annotations

import numpy as np

from cvt.boxes import box_iou
from cvt.canvas import Placed, moved_boxes
from cvt.torus import Torus


def wrap_centres(placed: list[Placed], boxes: np.ndarray, out_box) -> list[Placed]:
    """Each copy moved by whole periods so its box centre is on ``out_box``. Shape: boxes
    (E, 4)."""
    if not placed:
        return placed
    mb = moved_boxes(placed, boxes)
    c = (mb[:, :2] + mb[:, 2:]) / 2
    shift = Torus.of(out_box).wrap(c) - c  # (P, 2)
    return [(e, dx + float(s[0]), dy + float(s[1]))
            for (e, dx, dy), s in zip(placed, shift, strict=True)]


def wrap_around(placed: list[Placed], boxes: np.ndarray, out_box) -> list[Placed]:
    """Toroidal version of ``placed`` over ``out_box``, drawing order kept (wrapped copies
    right after their element). Shape: boxes (E, 4)."""
    x0, y0, x1, y1 = out_box
    w, h = x1 - x0, y1 - y0
    placed = wrap_centres(placed, boxes, out_box)
    mb = moved_boxes(placed, boxes)
    iou_in = box_iou(boxes, boxes)
    np.fill_diagonal(iou_in, 0)
    limit = max(0.15, float(iou_in.max()) + 0.1)
    shifts = [(i * w, j * h) for i in (-1, 0, 1) for j in (-1, 0, 1) if i or j]
    keep = np.ones(len(placed), bool)
    for sx, sy in [(0.0, 0.0), *shifts]:
        iou = box_iou(mb, mb + np.array([sx, sy, sx, sy]))  # element i vs wrapped j
        for i, j in zip(*np.nonzero(iou > limit), strict=True):
            if keep[i] and keep[j] and i != j:
                keep[max(i, j)] = False
    out = []
    for (e, dx, dy), b, k in zip(placed, mb, keep, strict=True):
        if not k:
            continue
        out.append((e, dx, dy))
        for sx, sy in shifts:
            nb = b + np.array([sx, sy, sx, sy])
            if nb[0] < x1 and nb[2] > x0 and nb[1] < y1 and nb[3] > y0:
                out.append((e, dx + sx, dy + sy))
    return out
