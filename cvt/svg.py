"""SVG in and out: an exemplar is a list of top-level elements with their original markup.

An element is one top-level drawable node of the document (a ``<g>`` group counts as one
element). Its geometry is read with svgelements (``<use>`` expanded, transforms applied) in
the document's user units (the viewBox space); its original XML is kept verbatim so the output
reproduces it exactly, only wrapped in a ``translate``. Untrusted input is parsed defensively:
no DTD (hence no entity expansion), no external fetches, bounded sizes.
"""

from __future__ import annotations

import copy
import io
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np
import svgelements as se

from cvt.background import covers, split_background
from cvt.elements import element_nodes, open_layers
from neuraltex.errors import InputError

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_NS = "http://www.w3.org/1999/xlink"
MAX_BYTES = 10_000_000
MAX_NODES = 200_000
MAX_ELEMENTS = 5_000
MAX_EXTENT = 1e7

# Non-rendered nodes that may be referenced by elements; carried over into the output <defs>.
_DEF_TAGS = {
    "defs", "style", "symbol", "clipPath", "mask", "linearGradient", "radialGradient",
    "pattern", "marker", "filter",
}
_SKIP_TAGS = {"title", "desc", "metadata", "script", "namedview"}
_UNSUPPORTED_TAGS = {"text", "image", "foreignObject"}
_ROOT_GEOMETRY_ATTRS = {"width", "height", "viewBox", "x", "y", "id", "version"}


@dataclass
class Shape:
    """One primitive of an element: flattened outline rings in user units."""

    rings: list[np.ndarray]  # each (P, 2); closed rings repeat no point
    closed: list[bool]
    filled: bool
    stroke_width: float  # 0 when not stroked
    evenodd: bool = False
    stroke_color: str | None = None  # '#rrggbb' when stroked (curve styles, cvt.curves)


def _box(shapes: list[Shape]) -> np.ndarray:
    """(4,) xmin, ymin, xmax, ymax of shapes, incl. half stroke width."""
    boxes = []
    for s in shapes:
        hw = s.stroke_width / 2
        for r in s.rings:
            boxes.append(np.r_[r.min(0) - hw, r.max(0) + hw])
    b = np.stack(boxes)
    return np.r_[b[:, :2].min(0), b[:, 2:].max(0)]


@dataclass
class Element:
    """A top-level drawable node: geometry for sampling plus its original XML."""

    index: int  # document order among elements == z-index
    node: ET.Element
    shapes: list[Shape]

    @property
    def bbox(self) -> np.ndarray:  # (4,) xmin, ymin, xmax, ymax incl. half stroke width
        return _box(self.shapes)

    @property
    def markup(self) -> str:
        return ET.tostring(self.node, encoding="unicode")


@dataclass
class Exemplar:
    elements: list[Element]
    viewbox: tuple[float, float, float, float]  # x, y, w, h in user units
    root_attrs: dict[str, str] = field(default_factory=dict)  # inherited presentation attrs
    defs: list[ET.Element] = field(default_factory=list)
    unit_scale: tuple[float, str] = (1.0, "")  # root width per user unit, and its unit suffix
    # Optional appearance attributes A (seed 000 sec. 4.2), one row per element, (E, D); e.g.
    # one-hot texton kinds (cvt.from_textons). None: spatial information only, as in the paper.
    appearance: np.ndarray | None = None
    # Canvas-covering content under the elements (cvt.background): carried to the output as
    # background, never arranged. Its elements keep their document order.
    background: list[Element] = field(default_factory=list)
    note: str = ""  # what the parser decided (element mode, background), one line

    @property
    def size(self) -> float:
        """Exemplar size: mean of width and height (seed 000 sec. 7.3)."""
        return (self.viewbox[2] + self.viewbox[3]) / 2


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1].rsplit(":", 1)[-1]


def _check_safe(data: bytes) -> None:
    if len(data) > MAX_BYTES:
        raise InputError(f"SVG is too large ({len(data)} bytes > {MAX_BYTES})")
    head = data.upper()
    if b"<!DOCTYPE" in head or b"<!ENTITY" in head:
        raise InputError("SVG with DOCTYPE/ENTITY declarations is not accepted (entity expansion)")


def _parse_xml(data: bytes) -> tuple[ET.Element, dict[str, str]]:
    namespaces: dict[str, str] = {}
    try:
        events = ET.iterparse(io.BytesIO(data), events=("start-ns", "end"))
        root = None
        count = 0
        for ev, item in events:
            if ev == "start-ns":
                namespaces.setdefault(item[0], item[1])
            else:
                count += 1
                root = item
                if count > MAX_NODES:
                    raise InputError(f"SVG has more than {MAX_NODES} nodes")
    except ET.ParseError as exc:
        raise InputError(f"malformed SVG/XML: {exc}") from None
    if root is None or _local(root.tag) != "svg":
        raise InputError("not an SVG document (root element is not <svg>)")
    return root, namespaces


def _length(value: str | None) -> tuple[float, str] | None:
    if value is None:
        return None
    m = re.fullmatch(r"\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-z%]*)\s*", value)
    if not m:
        return None
    return float(m.group(1)), m.group(2)


def _viewbox(root: ET.Element) -> tuple[tuple[float, float, float, float], tuple[float, str]]:
    w, h = _length(root.get("width")), _length(root.get("height"))
    vb = root.get("viewBox")
    if vb is not None:
        try:
            box = tuple(float(v) for v in re.split(r"[\s,]+", vb.strip()))
        except ValueError:
            raise InputError(f"bad viewBox {vb!r}") from None
        if len(box) != 4:
            raise InputError(f"bad viewBox {vb!r}")
    elif w is not None and h is not None and w[1] in ("", "px"):
        box = (0.0, 0.0, w[0], h[0])
    else:
        raise InputError("SVG needs a viewBox or numeric width and height")
    if not all(math.isfinite(v) and abs(v) < MAX_EXTENT for v in box) or box[2] <= 0 or box[3] <= 0:
        raise InputError(f"absurd SVG size (viewBox {box})")
    unit = (1.0, "")
    if w is not None and w[1] != "%" and w[0] > 0:
        unit = (w[0] / box[2], w[1])
    return box, unit  # type: ignore[return-value]


def _hidden(node: ET.Element) -> bool:
    style = node.get("style", "").replace(" ", "")
    return node.get("display") == "none" or "display:none" in style


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


def _shapes_of(doc: bytes) -> list[Shape]:
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
            if len(ring) >= 1 and np.isfinite(ring).all():
                rings.append(ring)
                closed.append(c)
        extent = max((float(np.ptp(r, axis=0).max()) for r in rings), default=0.0)
        if rings and (extent > 0 or stroked):
            sw = float(getattr(e, "implicit_stroke_width", None) or e.stroke_width or 1.0)
            sw = sw if stroked else 0.0
            evenodd = e.values.get("fill-rule", "nonzero") == "evenodd"
            color = e.stroke.hexrgb if stroked else None
            shapes.append(Shape(rings, closed, filled, sw, evenodd, color))
    return shapes


def _mini_doc(root: ET.Element, hidden: list[ET.Element], node: ET.Element) -> bytes:
    """A document with one visible node; everything it may reference sits in <defs>."""
    mini = ET.Element(f"{{{SVG_NS}}}svg", {"width": "100000", "height": "100000"})
    for k, v in root.attrib.items():
        if _local(k) not in _ROOT_GEOMETRY_ATTRS:
            mini.set(k, v)
    defs = ET.SubElement(mini, f"{{{SVG_NS}}}defs")
    defs.extend(hidden)
    mini.append(node)
    return ET.tostring(mini)


def parse_svg(data: bytes, elements: str = "groups") -> Exemplar:
    """Parse untrusted SVG bytes into an :class:`Exemplar` (raises InputError on bad input).

    ``elements`` says which nodes are elements (cvt.elements: "auto", "shapes", "groups"; the
    default "groups" is the file's top-level nodes). Background content (cvt.background) is
    split off into ``Exemplar.background``."""
    _check_safe(data)
    root, namespaces = _parse_xml(data)
    for prefix, uri in namespaces.items():  # keep the file's prefixes (inkscape:, sodipodi:)
        if prefix and not re.fullmatch(r"ns\d+", prefix) and uri not in (SVG_NS, XLINK_NS):
            try:
                ET.register_namespace(prefix, uri)
            except ValueError:
                pass
    ET.register_namespace("", SVG_NS)
    ET.register_namespace("xlink", XLINK_NS)
    box, unit = _viewbox(root)
    defs, candidates, unsupported = [], [], 0
    for child in root:
        if not isinstance(child.tag, str):
            continue
        tag = _local(child.tag)
        if tag in _DEF_TAGS:
            defs.append(child)
        elif tag in _UNSUPPORTED_TAGS:
            unsupported += 1
        elif tag not in _SKIP_TAGS and not _hidden(child):
            candidates.append(child)
    tops = candidates
    candidates, note = element_nodes(tops, elements, _drawable)
    if len(candidates) > MAX_ELEMENTS:
        raise InputError(f"SVG has more than {MAX_ELEMENTS} elements")
    defs = defs + _nested_defs(tops)
    by_id = _ids(defs + tops)
    styles = [n for d in defs for n in d.iter() if _local(n.tag) == "style"]

    def read(node: ET.Element) -> list[Shape]:
        hidden = styles + [by_id[i] for i in _reference_closure(node, by_id)]
        try:
            return _shapes_of(_mini_doc(root, hidden, node))
        except (ValueError, TypeError, IndexError, AttributeError, ZeroDivisionError) as exc:
            raise InputError(f"cannot read element <{_local(node.tag)}>: {exc}") from None

    pairs = [(node, read(node)) for node in candidates]
    if elements == "auto":  # a group spanning the canvas is a layer of the file, not a motif
        pairs, opened = open_layers(pairs, lambda sh: covers(_box(sh), box), read, _drawable)
        note += f", {opened} canvas-wide group(s) opened" if opened else ""
    elements = [Element(k, n, sh) for k, (n, sh) in enumerate(p for p in pairs if p[1])]
    if not elements:
        if unsupported:
            raise InputError("SVG has only text or raster <image> content; nothing to synthesize")
        raise InputError("SVG has no drawable elements")
    root_attrs = {k: v for k, v in root.attrib.items() if _local(k) not in _ROOT_GEOMETRY_ATTRS}
    # Referenced top-level elements must stay resolvable in the output: keep them as defs too.
    used = set().union(*(_refs(e.node) for e in elements)) if elements else set()
    referenced = [c for c in tops if c.get("id") in used]
    return split_background(Exemplar(elements, box, root_attrs, defs + referenced, unit,
                                     note=note))


def _drawable(node: ET.Element) -> bool:
    tag = _local(node.tag)
    return (tag not in _DEF_TAGS and tag not in _SKIP_TAGS and tag not in _UNSUPPORTED_TAGS
            and not _hidden(node))


def _nested_defs(tops: list[ET.Element]) -> list[ET.Element]:
    """Definitions inside groups (opened groups leave them behind), outermost ones only."""
    out: list[ET.Element] = []

    def walk(node: ET.Element) -> None:
        for child in node:
            if not isinstance(child.tag, str):
                continue
            if _local(child.tag) in _DEF_TAGS:
                out.append(child)
            else:
                walk(child)

    for top in tops:
        walk(top)
    return out


_REF = re.compile(r"#([^\s)'\"#]+)")


def _refs(node: ET.Element) -> set[str]:
    """Ids referenced (href="#id", url(#id)) anywhere inside ``node``."""
    return {m for n in node.iter() for v in n.attrib.values() if "#" in v
            for m in _REF.findall(v)}


def _ids(nodes: list[ET.Element]) -> dict[str, ET.Element]:
    """Id -> node for the given nodes and everything inside them (first one wins)."""
    out: dict[str, ET.Element] = {}
    for top in nodes:
        for n in top.iter():
            if n.get("id") and n.get("id") not in out:
                out[n.get("id")] = n
    return out


def _reference_closure(node: ET.Element, by_id: dict[str, ET.Element]) -> list[str]:
    """Ids ``node`` needs, directly or through what those ids reference in turn."""
    todo, seen = list(_refs(node)), set()
    while todo:
        i = todo.pop()
        if i in seen or i not in by_id:
            continue
        seen.add(i)
        todo.extend(_refs(by_id[i]))
    return sorted(seen)


def load_svg(path, elements: str = "groups") -> Exemplar:
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    return parse_svg(data, elements)


def _renamed_copy(node: ET.Element, suffix: str) -> ET.Element:
    """Deep copy with ids made unique; references inside the copy follow the rename."""
    node = copy.deepcopy(node)
    ids = {n.get("id") for n in node.iter() if n.get("id")}
    if not ids:
        return node
    pattern = re.compile(r"#(" + "|".join(re.escape(i) for i in ids) + r")\b")
    for n in node.iter():
        for k, v in n.attrib.items():
            if k == "id" and v in ids:
                n.set(k, v + suffix)
            elif "#" in v:
                n.set(k, pattern.sub(lambda m: f"#{m.group(1)}{suffix}", v))
    return node


def _fmt(v: float) -> str:
    return f"{v:.6g}"


def to_svg(exemplar: Exemplar, placements: list[tuple[int, float, float]],
           size: tuple[float, float], under: list[ET.Element] = (), clip: str | None = None,
           clip_all: bool = False) -> str:
    """Serialize ``placements`` = [(element index, dx, dy)] (in drawing order) as SVG text.

    ``size`` is the output extent in the exemplar's user units; the output viewBox starts at the
    exemplar's viewBox origin so untranslated elements land where they were. ``under`` nodes
    (the background) are drawn first, clipped to the path ``clip`` (a ``d``) when given;
    ``clip_all`` clips the elements to it too.
    """
    x0, y0 = exemplar.viewbox[:2]
    w, h = size
    scale, unit = exemplar.unit_scale
    root = ET.Element(f"{{{SVG_NS}}}svg", {
        "version": "1.1",
        "width": f"{_fmt(w * scale)}{unit}",
        "height": f"{_fmt(h * scale)}{unit}",
        "viewBox": f"{_fmt(x0)} {_fmt(y0)} {_fmt(w)} {_fmt(h)}",
    })
    for k, v in exemplar.root_attrs.items():
        root.set(k, v)
    defs = ET.SubElement(root, f"{{{SVG_NS}}}defs")
    for d in exemplar.defs:
        if _local(d.tag) == "defs":
            defs.extend(copy.deepcopy(list(d)))
        else:
            defs.append(copy.deepcopy(d))
    parent = back = root
    if clip is not None:
        cp = ET.SubElement(defs, f"{{{SVG_NS}}}clipPath", {"id": "cvt-clip"})
        ET.SubElement(cp, f"{{{SVG_NS}}}path", {"d": clip})
        back = ET.SubElement(root, f"{{{SVG_NS}}}g", {"clip-path": "url(#cvt-clip)"})
        parent = back if clip_all else root
    if not len(defs):
        root.remove(defs)
    for node in under:
        back.append(node)
        node.tail = "\n"
    for k, (idx, dx, dy) in enumerate(placements):
        move = {"transform": f"translate({_fmt(dx)},{_fmt(dy)})"}
        g = ET.SubElement(parent, f"{{{SVG_NS}}}g", move)
        g.append(_renamed_copy(exemplar.elements[idx].node, f"-c{k}"))
        g.tail = "\n"
    root.text = "\n"
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
