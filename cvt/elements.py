"""Which nodes of an SVG document are the elements to arrange (``--elements auto|shapes|groups``).

Authors say what belongs together: a top-level ``<g>`` (with its transform) is one element in
``groups`` mode. Wrappers that only organize the file are opened: an Inkscape layer
(``inkscape:groupmode="layer"``) in every mode, and in ``auto`` and ``shapes`` also a lone
top-level group holding everything. ``shapes``
opens every group down to its drawable leaves. Web background patterns often draw all their
motifs as one compound ``<path>``; ``auto`` and ``shapes`` split such a path into one path per
connected piece (subpaths whose boxes touch or nest stay together: holes and dots of a motif).
``auto`` keeps the file's groups, splits compound paths, and opens groups when the file has fewer
than two of them to arrange. Opened groups pass their transform and presentation attributes on
by a wrapper ``<g>`` around each child, so every element renders as it did in the file.
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

import numpy as np
import svgelements as se
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

MODES = ("auto", "shapes", "groups")
SVG_NS = "http://www.w3.org/2000/svg"
INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"
_OWN_ATTRS = {"id", f"{{{INKSCAPE_NS}}}groupmode", f"{{{INKSCAPE_NS}}}label"}
MIN_PIECES = 3  # a compound path is split when it has at least this many separate pieces


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1].rsplit(":", 1)[-1]


def _is_group(node: ET.Element) -> bool:
    return _local(node.tag) in ("g", "a")


def _is_layer(node: ET.Element) -> bool:
    return _is_group(node) and node.get(f"{{{INKSCAPE_NS}}}groupmode") == "layer"


def _open(group: ET.Element, keep) -> list[ET.Element]:
    """The group's children that ``keep`` accepts, each wrapped in a copy of the group's own
    attributes (transform, fill, style...) so it renders as inside the group."""
    attrs = {k: v for k, v in group.attrib.items() if k not in _OWN_ATTRS}
    out = []
    for child in group:
        if not isinstance(child.tag, str) or not keep(child):
            continue
        if attrs:
            wrap = ET.Element(f"{{{SVG_NS}}}g", attrs)
            wrap.append(child)
            out.append(wrap)
        else:
            out.append(child)
    return out


def _inner(node: ET.Element) -> ET.Element:
    """The node inside the wrappers that :func:`_open` added."""
    while _is_group(node) and len(node) == 1 and node.get("id") is None:
        node = node[0]
    return node


def _rewrap(node: ET.Element, leaf: ET.Element) -> ET.Element:
    """``node`` with its innermost wrapped node replaced by ``leaf``."""
    if node is _inner(node):
        return leaf
    top = _shallow(node)
    cur, src = top, node
    while True:
        child = src[0]
        if child is _inner(child):
            cur.append(leaf)
            return top
        cur.append(_shallow(child))
        cur, src = cur[0], child


def _shallow(node: ET.Element) -> ET.Element:
    """A childless copy with its own attribute dict."""
    return ET.Element(node.tag, dict(node.attrib))


def _pieces(d: str) -> list[str]:
    """A compound path's ``d`` split into connected pieces (absolute commands), or [d]."""
    try:
        subs = list(se.Path(d).as_subpaths())
    except (ValueError, TypeError, IndexError, AttributeError):
        return [d]
    if len(subs) < MIN_PIECES:
        return [d]
    boxes = []
    for s in subs:
        b = se.Path(s).bbox()
        if b is None:
            return [d]
        boxes.append(b)
    boxes = np.asarray(boxes, dtype=float)  # (S, 4)
    eps = 1e-6 * float(np.ptp(boxes, axis=0).max() + 1.0)
    touch = ((boxes[:, None, :2] <= boxes[None, :, 2:] + eps)
             & (boxes[None, :, :2] <= boxes[:, None, 2:] + eps)).all(-1)  # (S, S)
    count, roots = connected_components(csr_matrix(touch), directed=False)
    if count < MIN_PIECES:
        return [d]
    groups: dict[int, list[int]] = {}
    for i, r in enumerate(roots):
        groups.setdefault(int(r), []).append(i)
    return [" ".join(se.Path(subs[i]).d(relative=False) for i in idx)
            for idx in groups.values()]


def _split_paths(nodes: list[ET.Element]) -> tuple[list[ET.Element], int]:
    out, split = [], 0
    for node in nodes:
        leaf = _inner(node)
        if _local(leaf.tag) != "path" or not leaf.get("d"):
            out.append(node)
            continue
        parts = _pieces(leaf.get("d"))
        if len(parts) == 1:
            out.append(node)
            continue
        split += 1
        for k, d in enumerate(parts):
            piece = copy.deepcopy(leaf)
            piece.set("d", d)
            if leaf.get("id"):
                piece.set("id", f"{leaf.get('id')}-p{k}")
            out.append(_rewrap(node, piece))
    return out, split


def element_nodes(candidates: list[ET.Element], mode: str, keep) -> tuple[list[ET.Element], str]:
    """The element nodes among a document's top-level ``candidates`` and a one-line note of
    what was decided. ``keep(node)`` says whether a child node is drawable content."""
    if mode not in MODES:
        raise ValueError(f"elements mode must be one of {MODES}, got {mode!r}")
    nodes = list(candidates)
    opened = 0
    while True:  # layers and a lone wrapper group are file organization, not elements
        layers = [n for n in nodes if _is_group(_inner(n)) and (
            _is_layer(_inner(n)) or (len(nodes) == 1 and mode != "groups"))]
        if not layers:
            break
        nodes = [c for n in nodes for c in (_open_wrapped(n, keep) if n in layers else [n])]
        opened += len(layers)
    groups = sum(_is_group(_inner(n)) for n in nodes)
    chosen = mode
    if mode == "auto":
        chosen = "groups" if len(nodes) >= 2 else "shapes"
    if chosen == "shapes":
        while any(_is_group(_inner(n)) for n in nodes):
            nodes = [c for n in nodes
                     for c in (_open_wrapped(n, keep) if _is_group(_inner(n)) else [n])]
    split = 0
    if mode != "groups":
        nodes, split = _split_paths(nodes)
    note = f"elements: {mode}" + (f" -> {chosen}" if mode == "auto" else "")
    note += f", {len(nodes)} elements"
    if chosen == "groups" and groups:
        note += f" ({groups} groups kept whole)"
    if opened:
        note += f", {opened} layer/wrapper group(s) opened"
    if split:
        note += f", {split} compound path(s) split into pieces"
    return nodes, note


def _open_wrapped(node: ET.Element, keep) -> list[ET.Element]:
    """Open the group inside ``node``'s wrappers; each child keeps those wrappers."""
    inner = _inner(node)
    return [_rewrap(node, c) if node is not inner else c for c in _open(inner, keep)]


def open_layers(pairs: list[tuple[ET.Element, list]], spans, read, keep, depth: int = 3
                ) -> tuple[list[tuple[ET.Element, list]], int]:
    """Open groups of several drawable children whose geometry ``spans(shapes)`` the canvas
    (``auto``: such a group is a layer, a ground or a whole pattern, not a motif). ``pairs`` are
    (node, shapes); ``read(node)`` gives a node's shapes. Returns new pairs and the count."""
    opened = 0
    for _ in range(depth):
        out, changed = [], False
        for node, shapes in pairs:
            inner = _inner(node)
            kids = [c for c in inner if isinstance(c.tag, str) and keep(c)]
            if shapes and _is_group(inner) and len(kids) >= 2 and spans(shapes):
                new, _ = _split_paths(_open_wrapped(node, keep))
                out += [(n, read(n)) for n in new]
                opened += 1
                changed = True
            else:
                out.append((node, shapes))
        pairs = out
        if not changed:
            break
    return pairs, opened
