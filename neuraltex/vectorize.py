"""Segments -> SVG: one filled, outlined element per segment, in draw order, over a background.

Outlines are the zero level of a signed margin field (marching squares, skimage's
``find_contours``), so soft masks give sub-pixel boundaries and hard labels run between pixel
centres; holes are further rings of the same even-odd path. Rings are simplified
(Douglas-Peucker) and drawn as closed Catmull-Rom splines, i.e. cubic Béziers through the
kept points. Fills take the image colour under the segment: the mean, or a linear gradient
along one of the segment's principal axes (for textons, the Gaussian's axes, eqs. 4.4-4.5)
when that removes at least ``gradient_gain`` of the squared colour error.

Coordinates are image pixels (x right, y down; pixel (i, j) covers [j, j+1] x [i, i+1]).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

from neuraltex.segments import Segments
from neuraltex.svg_text import document, hex_colour, number

BACKGROUNDS = ("flat", "grid")


@dataclass(frozen=True)
class VectorizeParams:
    tolerance: float = 0.6  # Douglas-Peucker tolerance, pixels
    min_area: float = 4.0  # rings and segments smaller than this (pixels) are dropped
    gradient: bool = True  # allow linear gradients
    gradient_gain: float = 0.25  # minimal share of the flat fill's squared error removed
    seam: float = 0.8  # stroke width (pixels, same paint) that closes anti-aliasing seams
    background: str = "flat"  # or "grid": a coarse mesh of rectangles
    grid_cells: int = 4  # cells along the short side for background="grid"
    kinds: int = 4  # clusters of segment features -> data-kind


@dataclass
class Fill:
    colour: np.ndarray  # (3,) mean, in [0, 1]
    gradient: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None  # p0, p1, c0, c1


@dataclass
class VectorElement:
    segment: int  # row in Segments
    rings: list[np.ndarray]  # each (P, 2) x, y
    fill: Fill
    area: int  # pixels
    ellipse: tuple[float, float, float, float, float] | None = None  # cx, cy, rx, ry, degrees


@dataclass
class Vectorized:
    elements: list[VectorElement]  # bottom to top
    background: list[tuple[float, float, float, float, np.ndarray]]  # x, y, w, h, colour
    kinds: np.ndarray  # (K,) kind per segment
    size: tuple[int, int]  # (H, W)
    extra: dict = field(default_factory=dict)


def trace(mask: np.ndarray, margin: np.ndarray, params: VectorizeParams,
          offset: tuple[int, int] = (0, 0)) -> list[np.ndarray]:
    """Closed outline rings (outer and holes) of a boolean mask, in pixels of an image whose
    crop at ``offset`` = (row, col) the mask is. Shape: (h, w) -> [(P, 2)]."""
    from skimage.measure import find_contours

    ys, xs = np.nonzero(mask)
    y0, y1 = max(ys.min() - 1, 0), min(ys.max() + 2, mask.shape[0])
    x0, x1 = max(xs.min() - 1, 0), min(xs.max() + 2, mask.shape[1])
    m = margin[y0:y1, x0:x1] + 1e-3
    signed = np.pad(np.where(mask[y0:y1, x0:x1], m, -m), 1, constant_values=-1.0)
    rings = []
    for c in find_contours(signed, 0.0):  # (P, 2) row, col; closed (first == last)
        c = simplify(c[:-1], params.tolerance)
        if len(c) < 3 or _area(c) < params.min_area:
            continue
        # padded index -> pixel-centre coordinates: x = col - 1 + x0 + 0.5
        rings.append(np.stack([c[:, 1] + x0 + offset[1] - 0.5, c[:, 0] + y0 + offset[0] - 0.5], 1))
    return rings


def simplify(ring: np.ndarray, tolerance: float) -> np.ndarray:
    """Douglas-Peucker on a closed ring, split at its first point and the point farthest from
    it (skimage's version imports scipy.signal, seconds on a cold start). (P, 2) -> (Q, 2)."""
    if len(ring) < 4:
        return ring
    far = int(((ring - ring[0]) ** 2).sum(1).argmax())
    keep = np.zeros(len(ring), bool)
    keep[[0, far]] = True
    stack = [(0, far), (far, len(ring))]  # index len(ring) wraps to 0
    closed = np.vstack([ring, ring[:1]])
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        a, b, pts = closed[i], closed[j], closed[i + 1 : j]
        ab = b - a
        n = float(np.hypot(*ab))
        if n < 1e-12:
            d = np.hypot(*(pts - a).T)
        else:
            d = np.abs(ab[0] * (pts[:, 1] - a[1]) - ab[1] * (pts[:, 0] - a[0])) / n
        k = int(d.argmax())
        if d[k] > tolerance:
            keep[i + 1 + k] = True
            stack += [(i, i + 1 + k), (i + 1 + k, j)]
    return ring[keep]


def _area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def fit_fill(pixels: np.ndarray, colours: np.ndarray, params: VectorizeParams) -> Fill:
    """Mean colour, or a linear gradient along a principal axis of the pixel positions.

    Shape: pixels (N, 2) x, y; colours (N, 3).
    """
    mean = colours.mean(0)
    flat_err = float(((colours - mean) ** 2).sum())
    if not params.gradient or len(pixels) < 16 or flat_err <= 1e-9:
        return Fill(mean)
    centre = pixels.mean(0)
    d = pixels - centre
    _, axes = np.linalg.eigh(d.T @ d / len(d))  # columns: minor, major axis
    best = None
    for u in axes.T:
        t = d @ u  # (N,)
        var = float((t * t).mean())
        if var < 1e-6:
            continue
        slope = (t[:, None] * (colours - mean)).mean(0) / var  # (3,) least squares
        err = float(((colours - mean - t[:, None] * slope) ** 2).sum())
        if best is None or err < best[0]:
            best = (err, u, slope, np.sqrt(var))
    if best is None or best[0] > (1 - params.gradient_gain) * flat_err:
        return Fill(mean)
    _, u, slope, sd = best
    ends = 2 * sd  # the ends stops at +-2 sd; beyond that SVG pads with the end colours
    c0 = np.clip(mean - ends * slope, 0, 1)
    c1 = np.clip(mean + ends * slope, 0, 1)
    return Fill(mean, (centre - ends * u + 0.5, centre + ends * u + 0.5, c0, c1))


def kinds_of(features: np.ndarray, k: int) -> np.ndarray:
    """k-means kinds of segment features (standardized). Shape: (K, D) -> (K,) int."""
    from scipy.cluster.vq import kmeans2

    if len(features) == 0:
        return np.zeros(0, np.int64)
    x = ((features - features.mean(0)) / (features.std(0) + 1e-6)).astype(np.float64)
    k = min(k, len(np.unique(x, axis=0)))  # k-means++ cannot seed more centres than points
    if k <= 1:
        return np.zeros(len(x), np.int64)
    _, kinds = kmeans2(x, k, minit="++", seed=0)  # (K,)
    # relabel by first appearance so kinds do not depend on k-means' centre order
    _, first = np.unique(kinds, return_index=True)
    rank = np.argsort(np.argsort(first))
    return rank[kinds]


def vectorize(image: np.ndarray, seg: Segments,
              params: VectorizeParams | None = None) -> Vectorized:
    """Image (H, W, 3) in [0, 1] and its segments -> vector elements, bottom to top."""
    p = params or VectorizeParams()
    if p.background not in BACKGROUNDS:
        raise ValueError(f"background must be one of {BACKGROUNDS}")
    H, W = seg.labels.shape
    if image.shape[:2] != (H, W):
        raise ValueError(f"image {image.shape[:2]} and segments {(H, W)} differ in size")
    from scipy.ndimage import find_objects

    flat = seg.labels.ravel()
    area = np.bincount(flat[flat >= 0], minlength=seg.count)
    boxes = find_objects(seg.labels + 1, max_label=seg.count)  # box of label k at [k]
    elements = []
    for k in np.argsort(seg.order, kind="stable"):  # back to front (larger order in front)
        if area[k] < p.min_area:
            continue
        rows, cols = boxes[k]
        rows = slice(max(rows.start - 1, 0), min(rows.stop + 1, H))
        cols = slice(max(cols.start - 1, 0), min(cols.stop + 1, W))
        mask = seg.labels[rows, cols] == k  # (h, w) crop
        rings = trace(mask, seg.margin[rows, cols], p, (rows.start, cols.start))
        if rings:
            yy, xx = np.nonzero(mask)
            pos = np.stack([xx + cols.start, yy + rows.start], 1).astype(np.float64)  # (n, 2)
            rgb = image[rows, cols][mask].astype(np.float64)  # (n, 3)
            elements.append(VectorElement(int(k), rings, fit_fill(pos, rgb, p), int(area[k])))
    return Vectorized(elements, _background(image, seg.labels, p), kinds_of(seg.features, p.kinds),
                      (H, W))


def _background(image: np.ndarray, labels: np.ndarray, p: VectorizeParams):
    """Flat: the mean colour of the pixels no element covers (all pixels if none is free).
    Grid: mean colours of cells, grid_cells along the short side."""
    H, W = labels.shape
    if p.background == "flat":
        free = labels < 0
        colour = image[free].mean(0) if free.sum() >= 1 else image.reshape(-1, 3).mean(0)
        return [(0.0, 0.0, float(W), float(H), colour)]
    step = min(H, W) / p.grid_cells
    ny, nx = max(1, round(H / step)), max(1, round(W / step))
    ys = np.linspace(0, H, ny + 1).round().astype(int)
    xs = np.linspace(0, W, nx + 1).round().astype(int)
    return [(float(xs[j]), float(ys[i]), float(xs[j + 1] - xs[j]), float(ys[i + 1] - ys[i]),
             image[ys[i]:ys[i + 1], xs[j]:xs[j + 1]].reshape(-1, 3).mean(0))
            for i in range(ny) for j in range(nx)]


# ------------------------------------------------------------------------------- SVG text
def path_data(rings: list[np.ndarray]) -> str:
    """Closed Catmull-Rom splines through each ring's points as cubic Bézier path data."""
    parts = []
    for r in rings:
        prev, nxt, nxt2 = np.roll(r, 1, 0), np.roll(r, -1, 0), np.roll(r, -2, 0)
        c1 = r + (nxt - prev) / 6  # (P, 2) first control point of the segment r[i] -> r[i+1]
        c2 = nxt - (nxt2 - r) / 6
        d = [f"M{number(r[0, 0])} {number(r[0, 1])}"]
        for i in range(len(r)):
            d.append("C" + " ".join(number(v) for v in (*c1[i], *c2[i], *nxt[i])))
        parts.append("".join(d) + "Z")
    return "".join(parts)


def _shape(e: VectorElement, paint: str, seam: float) -> str:
    if e.ellipse is not None:  # --mode ellipse: a real <ellipse>, editable as one
        cx, cy, rx, ry, deg = (number(v) for v in e.ellipse)
        return (f'<ellipse cx="{cx}" cy="{cy}" rx="{rx}" ry="{ry}" '
                f'transform="rotate({deg} {cx} {cy})" fill="{paint}"/>')
    return (f'<path d="{path_data(e.rings)}" fill="{paint}" fill-rule="evenodd"'
            + (f' stroke="{paint}" stroke-width="{number(seam)}" stroke-linejoin="round"'
               if seam > 0 else "") + "/>")


def to_svg(vec: Vectorized, seg: Segments, seam: float = 0.8) -> str:
    """The SVG document: a background group, then one ``<g>`` per element, bottom to top."""
    H, W = vec.size
    defs, body = [], ['<g id="background" data-background="1">']
    for x, y, w, h, c in vec.background:
        body.append(f'<rect x="{number(x)}" y="{number(y)}" width="{number(w)}" '
                    f'height="{number(h)}" fill="{hex_colour(c)}"/>')
    body.append("</g>")
    for n, e in enumerate(vec.elements):
        k = e.segment
        paint = hex_colour(e.fill.colour)
        if e.fill.gradient is not None:
            p0, p1, c0, c1 = e.fill.gradient
            defs.append(f'<linearGradient id="fill-{n}" gradientUnits="userSpaceOnUse" '
                        f'x1="{number(p0[0])}" y1="{number(p0[1])}" '
                        f'x2="{number(p1[0])}" y2="{number(p1[1])}">'
                        f'<stop offset="0" stop-color="{hex_colour(c0)}"/>'
                        f'<stop offset="1" stop-color="{hex_colour(c1)}"/></linearGradient>')
            paint = f"url(#fill-{n})"
        attrs = {"id": f"texton-{int(seg.index[k])}", "data-texton": str(int(seg.index[k])),
                 "data-existence": f"{float(seg.existence[k]):.3f}",
                 "data-kind": f"k{int(vec.kinds[k])}", "data-order": str(int(seg.order[k]))}
        body.append("<g " + " ".join(f"{a}={quoteattr(v)}" for a, v in attrs.items()) + ">"
                    + _shape(e, paint, seam) + "</g>")
    return document(W, H, body, defs)


def ellipses(image: np.ndarray, seg: Segments, mu: np.ndarray, cov: np.ndarray,
             params: VectorizeParams | None = None, level: float = 1.0) -> Vectorized:
    """``--mode ellipse``: each segment's Gaussian as an ellipse at the M = ``level`` set,
    filled with the mean image colour of its segment. mu (K, 2), cov (K, 2, 2) are in the
    textons' normalized units (short side = 1), one row per segment."""
    import torch

    from neuraltex.textons import ellipse_axes, ellipse_points

    p = params or VectorizeParams()
    H, W = seg.labels.shape
    S = min(H, W)
    mu_px = torch.as_tensor(mu, dtype=torch.float64) * S  # (K, 2)
    cov_px = torch.as_tensor(cov, dtype=torch.float64) * S * S  # (K, 2, 2)
    rings = ellipse_points(mu_px, cov_px, level, n=17)[:, :-1].numpy()  # (K, 16, 2)
    a, b, ang = (x.double().numpy() for x in ellipse_axes(cov_px, level))
    flat = seg.labels.ravel()
    area = np.bincount(flat[flat >= 0], minlength=seg.count)
    rgb = image.reshape(-1, 3)
    elements = [VectorElement(int(k), [rings[k]], Fill(rgb[flat == k].mean(0)), int(area[k]),
                              (*mu_px[k].tolist(), a[k], b[k], np.degrees(ang[k])))
                for k in np.argsort(seg.order, kind="stable") if area[k] > 0]
    return Vectorized(elements, _background(image, seg.labels, p), kinds_of(seg.features, p.kinds),
                      (H, W))
