"""SVG in and out: an exemplar is a list of top-level elements with their original markup.

An element is one top-level drawable node of the document (a ``<g>`` group counts as one
element). Its geometry is read with svgelements (``<use>`` expanded, transforms applied) in
the document's user units (the viewBox space); its original XML is kept verbatim so the output
reproduces it exactly, only wrapped in a ``translate``. Untrusted input is parsed defensively
(cvt.xml_input): no DTD (hence no entity expansion), external references removed
(cvt.references), ``<use>`` cycles and expansion bombs refused (cvt.use_expansion), sizes
bounded (cvt.limits); geometry that is not finite or lies absurdly far from the canvas is dropped.
"""

from __future__ import annotations

import copy
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from cvt.background import covers, split_background
from cvt.element_geometry import ROOT_GEOMETRY_ATTRS, Shape, box_of, element_reader, ids, refs
from cvt.element_geometry import local as _local
from cvt.elements import element_nodes, open_layers
from cvt.limits import DEFAULT, SvgLimits
from cvt.references import strip_external
from cvt.xml_input import read_xml
from neuraltex.errors import InputError

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_NS = "http://www.w3.org/1999/xlink"
MAX_EXTENT = 1e7  # viewBox numbers (user units)

# Non-rendered nodes that may be referenced by elements; carried over into the output <defs>.
_DEF_TAGS = {
    "defs", "style", "symbol", "clipPath", "mask", "linearGradient", "radialGradient",
    "pattern", "marker", "filter",
}
_SKIP_TAGS = {"title", "desc", "metadata", "script", "namedview"}
_UNSUPPORTED_TAGS = {"text", "image", "foreignObject"}


@dataclass
class Element:
    """A top-level drawable node: geometry for sampling plus its original XML."""

    index: int  # document order among elements == z-index
    node: ET.Element
    shapes: list[Shape]

    @property
    def bbox(self) -> np.ndarray:  # (4,) xmin, ymin, xmax, ymax incl. half stroke width
        return box_of(self.shapes)

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
    warnings: list[str] = field(default_factory=list)  # what was ignored (external links...)

    @property
    def size(self) -> float:
        """Exemplar size: mean of width and height (seed 000 sec. 7.3)."""
        return (self.viewbox[2] + self.viewbox[3]) / 2


def _length(value: str | None) -> tuple[float, str] | None:
    if value is None:
        return None
    m = re.fullmatch(r"\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-z%]*)\s*", value)
    if not m:
        return None
    return float(m.group(1)), m.group(2)


def _viewbox(root: ET.Element, limits: SvgLimits
             ) -> tuple[tuple[float, float, float, float], tuple[float, str]]:
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
    limits.check(max(box[2] / box[3], box[3] / box[2]), "max_aspect", "SVG viewBox aspect ratio")
    unit = (1.0, "")
    if w is not None and w[1] != "%" and w[0] > 0:
        unit = (w[0] / box[2], w[1])
    return box, unit  # type: ignore[return-value]


def _hidden(node: ET.Element) -> bool:
    style = node.get("style", "").replace(" ", "")
    return node.get("display") == "none" or "display:none" in style


def parse_svg(data: bytes, elements: str = "groups", limits: SvgLimits = DEFAULT
              ) -> Exemplar:
    """Parse untrusted SVG bytes into an :class:`Exemplar` (raises InputError on bad input).

    ``elements`` says which nodes are elements (cvt.elements: "auto", "shapes", "groups"; the
    default "groups" is the file's top-level nodes). Background content (cvt.background) is
    split off into ``Exemplar.background``. ``limits`` bounds the work (cvt.limits)."""
    root, namespaces = read_xml(data, limits)
    if root is None or _local(root.tag) != "svg":
        raise InputError("not an SVG document (root element is not <svg>)")
    _register(namespaces)
    external = strip_external(root)
    box, unit = _viewbox(root, limits)
    defs, tops, unsupported = [], [], 0
    for child in root:
        if not isinstance(child.tag, str):
            continue
        tag = _local(child.tag)
        if tag in _DEF_TAGS:
            defs.append(child)
        elif tag in _UNSUPPORTED_TAGS:
            unsupported += 1
        elif tag not in _SKIP_TAGS and not _hidden(child):
            tops.append(child)
    candidates, note = element_nodes(tops, elements, _drawable)
    limits.check(len(candidates), "max_elements", "SVG elements")
    defs = defs + _nested_defs(tops)
    by_id = ids(defs + tops)
    read, reader, skipped = element_reader(root, defs, by_id, box, limits)
    pairs = [(node, read(node)) for node in candidates]
    if elements == "auto":  # a group spanning the canvas is a layer of the file, not a motif
        pairs, opened = open_layers(pairs, lambda sh: covers(box_of(sh), box), read, _drawable)
        note += f", {opened} canvas-wide group(s) opened" if opened else ""
    elements = [Element(k, n, sh) for k, (n, sh) in enumerate(p for p in pairs if p[1])]
    if not elements:
        if unsupported:
            raise InputError("SVG has only text or raster <image> content; nothing to synthesize")
        why = _warnings(0, reader.dropped, skipped)
        raise InputError("SVG has no drawable elements" + (f" ({why[0]})" if why else ""))
    limits.check(sum(len(r) for e in elements for s in e.shapes for r in s.rings), "max_points",
                 "flattened outline points")
    root_attrs = {k: v for k, v in root.attrib.items() if _local(k) not in ROOT_GEOMETRY_ATTRS}
    # Referenced top-level elements must stay resolvable in the output: keep them as defs too.
    used = set().union(*(refs(e.node) for e in elements)) if elements else set()
    referenced = [c for c in tops if c.get("id") in used]
    warnings = _warnings(external, reader.dropped, skipped)
    ex = split_background(Exemplar(elements, box, root_attrs, defs + referenced, unit,
                                   note=note, warnings=warnings))
    _check_on_canvas(ex)
    return ex


def _register(namespaces: dict[str, str]) -> None:
    for prefix, uri in namespaces.items():  # keep the file's prefixes (inkscape:, sodipodi:)
        if prefix and not re.fullmatch(r"ns\d+", prefix) and uri not in (SVG_NS, XLINK_NS):
            try:
                ET.register_namespace(prefix, uri)
            except ValueError:
                pass
    ET.register_namespace("", SVG_NS)
    ET.register_namespace("xlink", XLINK_NS)


def _warnings(external: int, dropped: int, skipped: list[str]) -> list[str]:
    out = []
    if external:
        out.append(f"ignored {external} external reference(s) (<image>/<use> href, CSS url, "
                   "@import): never read")
    if dropped:
        out.append(f"dropped {dropped} shape(s) with non-finite or absurdly far coordinates or "
                   "stroke width")
    if skipped:
        out.append(f"skipped {len(skipped)} element(s) that cannot be read ({skipped[0]})")
    return out


def _check_on_canvas(ex: Exemplar) -> None:
    """InputError when every element lies outside the viewBox: nothing on the canvas."""
    x, y, w, h = ex.viewbox
    for e in ex.elements + ex.background:
        b = e.bbox
        if b[0] < x + w and b[2] > x and b[1] < y + h and b[3] > y:
            return
    raise InputError(f"no element is on the canvas (viewBox {x:g} {y:g} {w:g} {h:g})")


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


def read_file(path, limits: SvgLimits) -> bytes:
    """The bytes of the SVG file at ``path`` (at most ``limits.max_bytes`` + 1 of them)."""
    try:
        with open(path, "rb") as f:
            return f.read(limits.max_bytes + 1)
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the name
        raise InputError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None


def load_svg(path, elements: str = "groups", limits: SvgLimits = DEFAULT) -> Exemplar:
    return parse_svg(read_file(path, limits), elements, limits)


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
