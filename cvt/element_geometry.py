"""The geometry of SVG elements: each element node is read alone (a small document holding it
and the definitions it references) by svgelements, ``<use>`` expanded and transforms applied,
and flattened into outline rings in user units (16 points per curve segment).

Reading is budgeted (cvt.limits): the expansion of ``<use>`` is checked first
(cvt.use_expansion), flattened points are counted as they are made, and shapes with non-finite
or absurdly far coordinates or stroke widths are dropped and counted.
"""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import svgelements as se

from cvt.limits import FAR, SvgLimits
from cvt.use_expansion import expanded_size
from neuraltex.errors import InputError

SVG_NS = "http://www.w3.org/2000/svg"
ROOT_GEOMETRY_ATTRS = {"width", "height", "viewBox", "x", "y", "id", "version"}


def local(tag: str) -> str:
    """A tag or attribute name without its namespace or prefix."""
    return tag.rsplit("}", 1)[-1].rsplit(":", 1)[-1]


@dataclass
class Shape:
    """One primitive of an element: flattened outline rings in user units."""

    rings: list[np.ndarray]  # each (P, 2); closed rings repeat no point
    closed: list[bool]
    filled: bool
    stroke_width: float  # 0 when not stroked
    evenodd: bool = False
    stroke_color: str | None = None  # '#rrggbb' when stroked (curve styles, cvt.curves)


def box_of(shapes: list[Shape]) -> np.ndarray:
    """(4,) xmin, ymin, xmax, ymax of shapes, incl. half stroke width."""
    boxes = []
    for s in shapes:
        hw = s.stroke_width / 2
        for r in s.rings:
            boxes.append(np.r_[r.min(0) - hw, r.max(0) + hw])
    b = np.stack(boxes)
    return np.r_[b[:, :2].min(0), b[:, 2:].max(0)]


def _ring_points(sub: se.Path) -> tuple[np.ndarray, bool]:
    pts: list[np.ndarray] = []
    closed = False
    for seg in sub:
        if isinstance(seg, se.Move):
            pts.append(np.array([[seg.end.x, seg.end.y]]))
        elif isinstance(seg, se.Close):
            closed = True
        elif isinstance(seg, se.Line):
            pts.append(np.array([[seg.end.x, seg.end.y]]))
        else:
            t = np.linspace(0, 1, 17)[1:]
            pts.append(np.asarray(seg.npoint(t), dtype=np.float64).reshape(-1, 2))
    ring = np.concatenate(pts) if pts else np.zeros((0, 2))
    if len(ring) > 1 and np.allclose(ring[0], ring[-1]):
        ring, closed = ring[:-1], True
    return ring, closed


@dataclass
class Reader:
    """What reading elements may still cost and what it dropped: flattened points are counted
    as they are made (reading stops when one element has more than ``--max-points``, or all
    reads together 4x that: auto mode reads some nodes twice) and shapes out of ``bounds``
    (x0, y0, x1, y1) are dropped."""

    limits: SvgLimits
    bounds: tuple[float, float, float, float]
    far: float  # stroke widths above this are absurd
    points: int = 0
    element_points: int = 0  # of the element being read
    dropped: int = 0

    def spend(self, n: int) -> None:
        self.points += n
        self.element_points += n
        self.limits.check(self.element_points, "max_points", "flattened outline points")
        if self.points > 4 * self.limits.max_points:
            self.limits.check(self.points, "max_points", "flattened outline points")

    def fits(self, rings: list[np.ndarray], stroke_width: float) -> bool:
        x0, y0, x1, y1 = self.bounds
        ok = stroke_width <= self.far and all(
            np.isfinite(r).all() and (r[:, 0] >= x0).all() and (r[:, 0] <= x1).all()
            and (r[:, 1] >= y0).all() and (r[:, 1] <= y1).all() for r in rings)
        self.dropped += not ok
        return ok


def shapes_of(doc: bytes, reader: Reader) -> list[Shape]:
    """Flattened shapes of a one-element document (geometry via svgelements)."""
    svg = se.SVG.parse(io.BytesIO(doc))
    shapes = []
    for e in svg.elements():
        if not isinstance(e, se.Shape) or e.values.get("visibility") in ("hidden", "collapse"):
            continue
        if e.values.get("display") == "none":
            continue
        filled = e.fill is not None and e.fill.value is not None
        stroked = e.stroke is not None and e.stroke.value is not None
        if not (filled or stroked):
            continue
        rings, closed = [], []
        path = abs(se.Path(e))  # bake any transform svgelements kept (e.g. rotated rounded rect)
        for sub in path.as_subpaths():
            ring, c = _ring_points(se.Path(sub))
            reader.spend(len(ring))
            if len(ring) >= 1 and np.isfinite(ring).all():
                rings.append(ring)
                closed.append(c)
        sw = float(getattr(e, "implicit_stroke_width", None) or e.stroke_width or 1.0)
        sw = sw if stroked else 0.0
        if not rings or not reader.fits(rings, sw):
            continue
        extent = max(float(np.ptp(r, axis=0).max()) for r in rings)
        if extent > 0 or stroked:
            evenodd = e.values.get("fill-rule", "nonzero") == "evenodd"
            color = e.stroke.hexrgb if stroked else None
            shapes.append(Shape(rings, closed, filled, sw, evenodd, color))
    return shapes


def mini_doc(root: ET.Element, hidden: list[ET.Element], node: ET.Element, box) -> bytes:
    """A document with one visible node; everything it may reference sits in <defs>. Its
    viewport is the viewBox's size (percentages resolve against it), in user units."""
    size = {"width": f"{box[2]!r}", "height": f"{box[3]!r}"}
    mini = ET.Element(f"{{{SVG_NS}}}svg", size)
    for k, v in root.attrib.items():
        if local(k) not in ROOT_GEOMETRY_ATTRS:
            mini.set(k, v)
    defs = ET.SubElement(mini, f"{{{SVG_NS}}}defs")
    defs.extend(hidden)
    mini.append(node)
    return ET.tostring(mini)


def element_reader(root, defs, by_id, box, limits: SvgLimits):
    """``read(node) -> shapes`` for element nodes (an element that cannot be read has no
    shapes; why goes into the returned ``skipped`` list), and its :class:`Reader`."""
    styles = [n for d in defs for n in d.iter() if local(n.tag) == "style"]
    far = FAR * (box[2] + box[3]) / 2
    reader = Reader(limits, (box[0] - far, box[1] - far, box[0] + box[2] + far,
                              box[1] + box[3] + far), far)
    skipped: list[str] = []
    expanded = [0]

    def read(node: ET.Element) -> list[Shape]:
        expanded[0] += expanded_size(node, by_id, limits)
        limits.check(expanded[0], "max_nodes", "SVG nodes after <use> expansion")
        hidden = styles + [by_id[i] for i in reference_closure(node, by_id)]
        reader.element_points = 0
        try:
            return shapes_of(mini_doc(root, hidden, node, box), reader)
        except (ValueError, TypeError, IndexError, AttributeError, ZeroDivisionError,
                OverflowError) as exc:
            if isinstance(exc, InputError):
                raise
            skipped.append(f"<{local(node.tag)}>: {str(exc)[:80]}")
            return []

    return read, reader, skipped


_REF = re.compile(r"#([^\s)'\"#]+)")


def refs(node: ET.Element) -> set[str]:
    """Ids referenced (href="#id", url(#id)) anywhere inside ``node``."""
    return {m for n in node.iter() for v in n.attrib.values() if "#" in v
            for m in _REF.findall(v)}


def ids(nodes: list[ET.Element]) -> dict[str, ET.Element]:
    """Id -> node for the given nodes and everything inside them (first one wins)."""
    out: dict[str, ET.Element] = {}
    for top in nodes:
        for n in top.iter():
            if n.get("id") and n.get("id") not in out:
                out[n.get("id")] = n
    return out


def reference_closure(node: ET.Element, by_id: dict[str, ET.Element]) -> list[str]:
    """Ids ``node`` needs, directly or through what those ids reference in turn."""
    todo, seen = list(refs(node)), set()
    while todo:
        i = todo.pop()
        if i in seen or i not in by_id:
            continue
        seen.add(i)
        todo.extend(refs(by_id[i]))
    return sorted(seen)
