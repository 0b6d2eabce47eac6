"""Element kinds: copies of one motif, for density, lattices and the real-world judge.

Two elements are of one kind when they have the same markup structure and colours (tags and
paint attributes, positions ignored), the same number of outline rings, and boxes and outline
areas of about the same size (within ``SIZE_TOL``): an X and an O of one colour differ.
:func:`exact_kinds` also tells apart turned and mirrored copies by their silhouette (a lattice
maps a motif onto translates only: the two mirrored rows of a lips stripe are two motifs). Elements
cut by the canvas border (``cut_mask``) are fragments: their visible part is not the motif, so
they are kept apart from whole ones.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from cvt.svg import Element

SIZE_TOL = 0.12
GRID = 8
GRID_TOL = 0.1
_PAINT = ("fill", "stroke", "stroke-width", "opacity", "fill-opacity", "class")
_STYLE = re.compile(r"(fill|stroke|stroke-width|opacity|fill-opacity)\s*:\s*([^;]+)")


def signature(e: Element) -> str:
    """Markup structure and paint of an element, positions ignored."""
    parts = []
    for n in e.node.iter():
        tag = n.tag.rsplit("}", 1)[-1] if isinstance(n.tag, str) else "?"
        paint = [f"{k}={n.get(k)}" for k in _PAINT if n.get(k) is not None]
        paint += [f"{k}={v.strip()}" for k, v in _STYLE.findall(n.get("style", ""))]
        parts.append(tag + "[" + ",".join(paint) + "]")
    return "/".join(parts)


def cut_mask(elements: list[Element], viewbox) -> np.ndarray:
    """Fragments: elements whose geometry was cut at the canvas border (their box ends on it,
    from inside), or that are clipped and cross it. An element that merely reaches past the
    border is whole (the SVG only hides the outside). Shape: (E,) bool."""
    if not elements:
        return np.zeros(0, bool)
    boxes = np.stack([e.bbox for e in elements])  # (E, 4)
    x, y, w, h = viewbox
    eps = 1e-4 * max(w, h)
    lo, hi = np.array([x, y]), np.array([x + w, y + h])
    inside = (boxes[:, :2] >= lo - eps).all(1) & (boxes[:, 2:] <= hi + eps).all(1)
    on_border = np.array([_straight_on_border(e, lo, hi, eps) for e in elements])
    clipped = np.array([any(n.get("clip-path") or n.get("mask") for n in e.node.iter())
                        for e in elements])
    cut = (inside & on_border) | (~inside & clipped)
    kinds = element_kinds(elements)  # a copy of an uncut element is whole (a border square)
    whole_kinds = set(kinds[~cut].tolist())
    return cut & ~np.isin(kinds, list(whole_kinds))


def _straight_on_border(e: Element, lo: np.ndarray, hi: np.ndarray, eps: float) -> bool:
    """Whether the outline runs along a canvas border line for a stretch (a cut edge), not
    just touches it (a dot tangent to the border is whole)."""
    rings = [r for s in e.shapes for r in s.rings]
    pts = np.concatenate(rings)  # (P, 2)
    ext = np.ptp(pts, axis=0)
    for axis in (0, 1):
        for line in (lo[axis], hi[axis]):
            on = pts[np.abs(pts[:, axis] - line) <= eps, 1 - axis]
            if len(on) >= 2 and np.ptp(on) > 0.2 * ext[1 - axis]:
                return True
            if any(_edge_on_line(r, axis, line, eps, 0.05 * ext[1 - axis]) for r in rings):
                return True
    return False


def _edge_on_line(ring: np.ndarray, axis: int, line: float, eps: float, min_len: float) -> bool:
    """Whether one outline edge (two consecutive points) lies on the border line: a thin
    stroke cut across (the cut edge is only as long as the stroke is wide). A curve tangent
    to the line has no such edge. Shape: ring (P, 2)."""
    nxt = np.roll(ring, -1, axis=0)
    on = (np.abs(ring[:, axis] - line) <= eps) & (np.abs(nxt[:, axis] - line) <= eps)
    return bool((on & (np.abs(nxt[:, 1 - axis] - ring[:, 1 - axis]) > max(min_len, 10 * eps))
                 ).any())


def element_kinds(elements: list[Element], cut: np.ndarray | None = None) -> np.ndarray:
    """Kind id per element (0..K-1), first-seen order. Shape: (E,) long."""
    boxes = np.stack([e.bbox for e in elements]) if elements else np.zeros((0, 4))
    size = boxes[:, 2:] - boxes[:, :2]  # (E, 2)
    stats = [ring_stats(e) for e in elements]
    sigs = [f"{signature(e)}|{n}" for e, (n, _) in zip(elements, stats, strict=True)]
    area = np.array([[a, a] for _, a in stats])
    cut = np.zeros(len(elements), bool) if cut is None else cut
    return _first_seen(len(elements), lambda r, i: (
        sigs[r] == sigs[i] and cut[r] == cut[i] and _close(size[r], size[i])
        and _close(area[r], area[i])))


def ring_stats(e: Element) -> tuple[int, float]:
    """Number of rings and their total |shoelace area| (filled shapes) of an element."""
    n, area = 0, 0.0
    for s in e.shapes:
        for r in s.rings:
            n += 1
            area += 0.5 * abs(float(np.dot(r[:, 0], np.roll(r[:, 1], 1))
                                    - np.dot(r[:, 1], np.roll(r[:, 0], 1))))
    return n, area


def exact_kinds(elements: list[Element], kinds: np.ndarray) -> np.ndarray:
    """``kinds`` split by silhouette (:func:`silhouette`, at most ``GRID_TOL`` of the cells
    differing): one kind holds translated copies only. Shape: (E,) -> (E,) long."""
    grids = [silhouette(e, e.bbox) for e in elements]
    return _first_seen(len(elements), lambda r, i: (
        kinds[r] == kinds[i] and (grids[r] != grids[i]).mean() <= GRID_TOL))


def silhouette(e: Element, box: np.ndarray) -> np.ndarray:
    """Which cells of a ``GRID`` x ``GRID`` grid over the element's box its filled rings and
    strokes cover: equal for copies, mirrored for a mirror image. Shape: (GRID, GRID) bool."""
    from PIL import Image, ImageDraw

    img = Image.new("1", (GRID, GRID), 0)
    draw = ImageDraw.Draw(img)
    scale = GRID / np.maximum(box[2:] - box[:2], 1e-9)
    for s in e.shapes:
        for ring in s.rings:
            xy = [tuple(p) for p in ((ring - box[:2]) * scale).tolist()]
            if s.filled and len(xy) >= 3:
                draw.polygon(xy, fill=1)
            elif len(xy) >= 2:
                draw.line(xy, fill=1)
    return np.asarray(img, dtype=bool)


def _first_seen(n: int, same) -> np.ndarray:
    """Group ids 0..K-1 in first-seen order: item i joins the first group whose first item r
    has ``same(r, i)``. Shape: (n,) long."""
    ids = np.full(n, -1)
    reps: list[int] = []
    for i in range(n):
        ids[i] = next((k for k, r in enumerate(reps) if same(r, i)), len(reps))
        if ids[i] == len(reps):
            reps.append(i)
    return ids


def _close(a: np.ndarray, b: np.ndarray) -> bool:
    return bool((np.abs(a - b) <= SIZE_TOL * np.maximum(np.maximum(a, b), 1e-9)).all())
