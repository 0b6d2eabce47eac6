"""Pixels of vector patterns: whole-document renders (resvg) and per-element coverage masks
(PIL polygons), both for the quantitative metrics and the previews.

Every render goes through :func:`png_bytes`: external references are stripped first
(cvt.references; resvg would read local files named by ``<image href>``), relative links resolve
in an empty folder, and the picture's size is bounded.
"""

from __future__ import annotations

import io
import math
import re
import tempfile
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

from cvt.references import safe_svg_text
from cvt.svg import Element

MAX_RENDER_SIDE = 4096  # longest side of a render, px (previews, metrics)
MIN_RENDER_SIDE = 16  # documents smaller than this (e.g. a 1e-6 viewBox) are scaled up


def png_bytes(text: str, width: int | None = None, background: str = "white") -> bytes:
    """PNG of SVG text, ``width`` px wide (default: the document's own size, scaled into
    [MIN_RENDER_SIDE, MAX_RENDER_SIDE] on the longest side). ValueError when it cannot render."""
    import resvg_py

    text = safe_svg_text(text)
    if width is None:
        text, width = _pixel_size(text)
    with tempfile.TemporaryDirectory() as empty:  # relative links find nothing
        png = resvg_py.svg_to_bytes(svg_string=text, background=background, width=width,
                                    skip_system_fonts=True, resources_dir=empty)
    return bytes(png)


_SIZE = re.compile(r'(\s(width|height)=")([^"]+)(")')


def _pixel_size(text: str) -> tuple[str, int | None]:
    """The text with its root width/height in px (resvg reads no mm, cm, in...), and a render
    width bringing the longest side into the bounds, or None to keep the document's size."""
    import svgelements as se

    start = text.find("<svg")
    end = text.find(">", start) + 1
    if start < 0 or end <= 0:
        return text, None
    px = {}
    for m in _SIZE.finditer(text, start, end):
        try:
            v = se.Length(m.group(3)).value(ppi=96)
        except (ValueError, TypeError):
            return text, None
        if not isinstance(v, float | int) or not math.isfinite(v) or v <= 0:
            return text, None
        px[m.group(2)] = float(v)
    if len(px) != 2:
        return text, None
    head = _SIZE.sub(lambda m: f"{m.group(1)}{px[m.group(2)]:.6g}{m.group(4)}", text[start:end])
    text = text[:start] + head + text[end:]
    longest = max(px.values())
    if MIN_RENDER_SIDE <= longest <= MAX_RENDER_SIDE:
        return text, None
    side = MAX_RENDER_SIDE if longest > MAX_RENDER_SIDE else MIN_RENDER_SIDE
    return text, max(1, round(px["width"] * side / longest))


def render_svg(text: str) -> np.ndarray:
    """RGB render of SVG text on white, at the document's pixel size (bounded, see
    :func:`png_bytes`). Shape: -> (H, W, 3) float in [0, 1]."""
    png = png_bytes(text)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float32) / 255


@dataclass
class Mask:
    """Coverage of one placed element: a boolean crop and its top-left pixel."""

    pixels: np.ndarray  # (h, w) bool
    x0: int
    y0: int

    @property
    def area(self) -> int:
        return int(self.pixels.sum())


def element_mask(element: Element, dx: float, dy: float, origin, scale: float) -> Mask:
    """Pixels covered by an element translated by (dx, dy): filled rings (holes ignored) and
    stroked outlines, at ``scale`` pixels per user unit, ``origin`` the user point of pixel 0."""
    box = (element.bbox + [dx, dy, dx, dy] - np.r_[origin, origin]) * scale
    x0, y0 = int(np.floor(box[0])) - 1, int(np.floor(box[1])) - 1
    w, h = int(np.ceil(box[2])) - x0 + 2, int(np.ceil(box[3])) - y0 + 2
    img = Image.new("1", (max(w, 1), max(h, 1)), 0)
    draw = ImageDraw.Draw(img)
    for shape in element.shapes:
        for ring, closed in zip(shape.rings, shape.closed, strict=True):
            pts = (ring + [dx, dy] - origin) * scale - [x0, y0]
            xy = [tuple(p) for p in pts.tolist()]
            if shape.filled and len(xy) >= 3:
                draw.polygon(xy, fill=1)
            if shape.stroke_width > 0 and len(xy) >= 2:
                draw.line(xy + (xy[:1] if closed else []), fill=1,
                          width=max(1, round(shape.stroke_width * scale)))
    return Mask(np.asarray(img, dtype=bool), x0, y0)


def overlap(a: Mask, b: Mask) -> int:
    """Number of pixels two masks share."""
    x0, y0 = max(a.x0, b.x0), max(a.y0, b.y0)
    x1 = min(a.x0 + a.pixels.shape[1], b.x0 + b.pixels.shape[1])
    y1 = min(a.y0 + a.pixels.shape[0], b.y0 + b.pixels.shape[0])
    if x1 <= x0 or y1 <= y0:
        return 0
    pa = a.pixels[y0 - a.y0 : y1 - a.y0, x0 - a.x0 : x1 - a.x0]
    pb = b.pixels[y0 - b.y0 : y1 - b.y0, x0 - b.x0 : x1 - b.x0]
    return int((pa & pb).sum())
