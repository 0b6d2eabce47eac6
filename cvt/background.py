"""Background content: found in the exemplar, carried to the output, never arranged.

The background is the run of bottom-most elements that each cover the canvas (their box spans
at least ``COVER`` of the viewBox width and height: a backdrop ``<rect>``, a ground layer), plus
a ground colour given on the root (``style="background-color: ..."``). In the output a plain
rectangle is stretched to the output canvas (a flat colour or a gradient stretch fine); anything
with inner structure (a ``<pattern>`` fill, a layer of shapes) is tiled at the exemplar's size.
"""

from __future__ import annotations

import copy
import dataclasses
import re
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from cvt.svg import Element, Exemplar

SVG_NS = "http://www.w3.org/2000/svg"
COVER = 0.9  # share of the viewBox width and height a background element spans
_GROUND = re.compile(r"background(?:-color)?\s*:\s*([^;]+)")


def covers(box: np.ndarray, viewbox) -> bool:
    """Whether an element box (x0, y0, x1, y1) spans the canvas in both directions."""
    x, y, w, h = viewbox
    span_x = min(box[2], x + w) - max(box[0], x)
    span_y = min(box[3], y + h) - max(box[1], y)
    return span_x >= COVER * w and span_y >= COVER * h


def split_background(ex: Exemplar) -> Exemplar:
    """``ex`` with its bottom run of canvas-covering, filled elements moved to ``background``
    (strokes alone, such as a drawing of curves, are content even when they span the canvas)."""
    n = 0
    while (n < len(ex.elements) and covers(ex.elements[n].bbox, ex.viewbox)
           and any(s.filled for s in ex.elements[n].shapes)):
        n += 1
    ground = _root_ground(ex)
    if n == 0 and ground is None:
        return ex
    background = ([ground] if ground is not None else []) + ex.elements[:n]
    rest = [dataclasses.replace(e, index=i) for i, e in enumerate(ex.elements[n:])]
    app = None if ex.appearance is None else ex.appearance[n:]
    pats = _pattern_ids(ex)
    note = f"{ex.note}, background: " + ", ".join(_describe(e, pats) for e in background)
    return dataclasses.replace(ex, elements=rest, background=background, appearance=app,
                               note=note.lstrip(", "))


def _root_ground(ex: Exemplar) -> Element | None:
    """The root's background colour as a canvas rectangle element, if it has one."""
    from cvt.svg import Element, Shape

    m = _GROUND.search(ex.root_attrs.get("style", ""))
    if not m or m.group(1).strip() in ("none", "transparent"):
        return None
    x, y, w, h = ex.viewbox
    node = ET.Element(f"{{{SVG_NS}}}rect", {"x": f"{x:g}", "y": f"{y:g}", "width": f"{w:g}",
                                             "height": f"{h:g}", "fill": m.group(1).strip()})
    ring = np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]], dtype=float)
    return Element(-1, node, [Shape([ring], [True], True, 0.0)])


def _describe(e: Element, pattern_ids: set[str]) -> str:
    tag = e.node.tag.rsplit("}", 1)[-1]
    return f"<{tag}> ({'stretched' if _stretchable(e, pattern_ids) else 'tiled'})"


def _pattern_ids(ex: Exemplar) -> set[str]:
    return {n.get("id") for d in ex.defs for n in d.iter()
            if n.tag.endswith("pattern") and n.get("id")}


def _stretchable(e: Element, pattern_ids: set[str]) -> bool:
    """A plain rectangle (one ring filling its box) without a pattern fill."""
    if any(f"#{i})" in v for n in e.node.iter() for v in n.attrib.values() for i in pattern_ids):
        return False
    if len(e.shapes) != 1 or len(e.shapes[0].rings) != 1:
        return False
    ring = e.shapes[0].rings[0]
    area = 0.5 * abs(np.dot(ring[:, 0], np.roll(ring[:, 1], 1))
                     - np.dot(ring[:, 1], np.roll(ring[:, 0], 1)))
    box = np.ptp(ring, axis=0)
    return area >= 0.97 * box[0] * box[1]


def backdrop_nodes(ex: Exemplar, out_box) -> list[ET.Element]:
    """SVG nodes that draw ``ex``'s background over ``out_box`` (x0, y0, x1, y1)."""
    pats = _pattern_ids(ex)
    x, y, w, h = ex.viewbox
    ow, oh = out_box[2] - out_box[0], out_box[3] - out_box[1]
    nodes = []
    for k, e in enumerate(ex.background):
        if _stretchable(e, pats):
            sx, sy = ow / w, oh / h  # the canvas-covering box keeps its margins, scaled
            t = (f"translate({_f(x)},{_f(y)}) scale({_f(sx)},{_f(sy)}) "
                 f"translate({_f(-x)},{_f(-y)})")
            nodes.append(_wrapped(e.node, t, f"-bg{k}"))
            continue
        for i in range(int(np.ceil(ow / w))):
            for j in range(int(np.ceil(oh / h))):
                nodes.append(_wrapped(e.node, f"translate({_f(i * w)},{_f(j * h)})",
                                      f"-bg{k}-{i}-{j}"))
    return nodes


def _wrapped(node: ET.Element, transform: str, suffix: str) -> ET.Element:
    from cvt.svg import _renamed_copy

    g = ET.Element(f"{{{SVG_NS}}}g", {"transform": transform})
    g.append(_renamed_copy(copy.deepcopy(node), suffix))
    return g


def _f(v: float) -> str:
    return f"{v:.6g}"
