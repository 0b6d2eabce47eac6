"""``<use>`` references, checked before anything expands them: a cycle (a node using itself,
directly, mutually or through ``<defs>``) is refused, and so is a chain deeper than
``--max-depth`` or a document that would expand to more than ``--max-nodes`` nodes (a chain of
ten uses of ten uses... draws 10^7 shapes from a few hundred bytes).

The expanded size of a node is its own node count plus, for each ``<use>`` inside it, the
expanded size of the node it references; it is computed once per id, without recursion.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from cvt.limits import SvgLimits
from neuraltex.errors import InputError


def _use_target(node: ET.Element) -> str | None:
    if not isinstance(node.tag, str) or node.tag.rsplit("}", 1)[-1] != "use":
        return None
    for key, value in node.attrib.items():
        if key.rsplit("}", 1)[-1] == "href" and value.strip().startswith("#"):
            return value.strip()[1:]
    return None


def _own(node: ET.Element) -> tuple[int, list[str]]:
    """(node count of ``node``'s subtree, ids its ``<use>`` nodes reference)."""
    count, refs = 0, []
    for n in node.iter():
        count += 1
        target = _use_target(n)
        if target is not None:
            refs.append(target)
    return count, refs


def expanded_size(node: ET.Element, by_id: dict[str, ET.Element], limits: SvgLimits) -> int:
    """Nodes ``node`` draws with every ``<use>`` expanded; InputError on a cycle, a chain
    deeper than ``limits.max_depth`` or more than ``limits.max_nodes`` nodes."""
    size: dict[str, int] = {}
    own = {}

    def parts(i: str) -> tuple[int, list[str]]:
        if i not in own:
            own[i] = _own(by_id[i])
        return own[i]

    count, refs = _own(node)
    for start in refs:
        stack, on_stack = [start], {start}  # depth-first over ids, post-order sums
        while stack:
            i = stack[-1]
            if i in size or i not in by_id:
                size.setdefault(i, 0)  # a missing id draws nothing
                on_stack.discard(stack.pop())
                continue
            todo = [r for r in parts(i)[1] if r not in size and r in by_id]
            cyclic = [r for r in todo if r in on_stack]
            if cyclic:
                raise InputError(f"<use> references form a cycle (#{cyclic[0]} uses itself "
                                 "through " + " -> ".join(f"#{s}" for s in stack[-4:]) + ")")
            if todo:
                limits.check(len(stack) + 1, "max_depth", "chain of <use> references")
                stack.append(todo[0])
                on_stack.add(todo[0])
                continue
            total = parts(i)[0] + sum(size.get(r, 0) for r in parts(i)[1])
            size[i] = min(total, limits.max_nodes + 1)  # no need to count past the limit
            on_stack.discard(stack.pop())
        count += size[start]
        limits.check(count, "max_nodes", "SVG nodes after <use> expansion")
    return count
