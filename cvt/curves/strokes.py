"""SVG in: the strokes (open and closed paths, polylines, lines, shapes drawn without fill) and
the discrete elements of a curve exemplar, in user units.

Geometry comes from ``cvt.svg.parse_svg`` (safe parsing, groups, transforms, ``<use>``); a
top-level element with any filled shape is one discrete element (reproduced from its markup),
otherwise each of its stroked rings is a stroke with the shape's colour and width.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cvt.curves.graph import StrokeStyle
from cvt.limits import DEFAULT, SvgLimits
from cvt.svg import Exemplar, parse_svg, read_file
from neuraltex.errors import InputError

MAX_STROKE_POINTS = 2_000_000  # flattened points over all strokes


@dataclass
class Stroke:
    points: np.ndarray  # (P, 2) flattened polyline; closed ones do not repeat the first point
    closed: bool
    style: int  # index into CurveExemplar.styles


@dataclass
class CurveExemplar:
    exemplar: Exemplar  # the parsed document (viewBox, defs, element markup)
    strokes: list[Stroke]
    styles: list[StrokeStyle]
    elements: list[int]  # indices (into exemplar.elements) of the discrete elements

    @property
    def box(self) -> tuple[float, float, float, float]:
        x, y, w, h = self.exemplar.viewbox
        return x, y, x + w, y + h

    def element_centers(self) -> np.ndarray:
        """Shape: -> (E_all, 2) bounding-box centres of all exemplar elements, by index."""
        b = [e.bbox for e in self.exemplar.elements]
        return np.array([[(x0 + x1) / 2, (y0 + y1) / 2] for x0, y0, x1, y1 in b]).reshape(-1, 2)


def curve_share(ex: Exemplar) -> float:
    """Share of the exemplar's shapes that are strokes without fill."""
    shapes = [s for e in ex.elements for s in e.shapes]
    return sum(not s.filled and s.stroke_width > 0 for s in shapes) / max(len(shapes), 1)


def looks_like_curves(ex: Exemplar, min_share: float = 0.25, long: float = 0.35) -> bool:
    """Auto-detection of curve content: enough unfilled strokes, and they connect (junctions
    or crossings) or run long (a stroke longer than ``long`` x the exemplar size). Separate
    short strokes (rings, swirls, hatching) stay discrete elements."""
    from cvt.curves.sampling import stroke_graph

    if curve_share(ex) < min_share:
        return False
    try:
        cx = curve_exemplar(ex)
    except InputError:
        return False
    if max(_length(s.points, s.closed) for s in cx.strokes) >= long * ex.size:
        return True
    return bool((stroke_graph(cx.strokes, cx.styles, ex.size / 36).degree() >= 3).any())


def _length(points: np.ndarray, closed: bool) -> float:
    p = np.vstack([points, points[:1]]) if closed else points
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def curve_exemplar(ex: Exemplar) -> CurveExemplar:
    """Split a parsed SVG into strokes and discrete elements (raises InputError if empty)."""
    styles: dict[StrokeStyle, int] = {}
    strokes, elements, total = [], [], 0
    for e in ex.elements:
        if any(s.filled for s in e.shapes):
            elements.append(e.index)
            continue
        for s in e.shapes:
            style = StrokeStyle(s.stroke_color or "#000000", float(s.stroke_width))
            k = styles.setdefault(style, len(styles))
            for ring, closed in zip(s.rings, s.closed, strict=True):
                ring = _dedupe(ring)
                if len(ring) < 2 or _length(ring, closed) <= 1e-9 * ex.size:
                    continue  # a single point or a zero-length stroke draws nothing to continue
                total += len(ring)
                strokes.append(Stroke(ring, closed and len(ring) >= 3, k))
    if total > MAX_STROKE_POINTS:
        raise InputError(f"strokes are too detailed ({total:,} points > {MAX_STROKE_POINTS:,})")
    if not strokes:
        raise InputError("the SVG has no strokes of positive length (no curve content)")
    return CurveExemplar(ex, strokes, list(styles), elements)


def _dedupe(points: np.ndarray) -> np.ndarray:
    """Drop consecutive repeated points. Shape: (P, 2) -> (P', 2)."""
    if len(points) < 2:
        return points
    keep = np.r_[True, np.linalg.norm(np.diff(points, axis=0), axis=1) > 0]
    return points[keep]


def load_curves(path, limits: SvgLimits = DEFAULT) -> CurveExemplar:
    return curve_exemplar(parse_svg(read_file(path, limits), limits=limits))
