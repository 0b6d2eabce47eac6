"""Resource bounds of SVG input, decided before any geometry is computed, so a hostile file
fails fast with one line instead of hanging or taking gigabytes (README, "Limits").

Every ``cvt`` command reading an SVG takes the options below to raise a bound. The defaults
sit well above the real-world corpus (data/cvt_real: at most 408 elements, 94k outline points,
6 levels of nesting, aspect ratio 1.75) and keep every command under ~2 GB and a minute.
"""

from __future__ import annotations

from dataclasses import dataclass

from neuraltex.errors import InputError

MAX_BYTES = 10_000_000  # --max-bytes: file size
MAX_NODES = 200_000  # --max-nodes: XML nodes, and shapes after <use> expansion
MAX_DEPTH = 100  # --max-depth: nesting of XML nodes and of <use> references
MAX_ELEMENTS = 500  # --max-elements: elements to arrange (500 random dots at --scale 2: 40 s)
MAX_POINTS = 150_000  # --max-points: flattened outline points of the whole document
MAX_ASPECT = 20.0  # --max-aspect: viewBox width / height (either way)
FAR = 1e4  # geometry farther than this many exemplar sizes from the canvas is dropped


@dataclass(frozen=True)
class SvgLimits:
    """The SVG budget of one command (from ``--max-bytes/nodes/depth/elements/points/aspect``)."""

    max_bytes: int = MAX_BYTES
    max_nodes: int = MAX_NODES
    max_depth: int = MAX_DEPTH
    max_elements: int = MAX_ELEMENTS
    max_points: int = MAX_POINTS
    max_aspect: float = MAX_ASPECT

    def check(self, value: float, limit: str, what: str) -> None:
        """InputError naming the option when ``value`` is above the limit ``limit``."""
        cap = getattr(self, limit)
        if value > cap:
            raise InputError(f"{what}: more than the limit of {cap:,g} (raise it with "
                             f"--{limit.replace('_', '-')})")


DEFAULT = SvgLimits()

ARGUMENTS = {  # option -> (type, help); every reader of SVG files offers them
    "max_bytes": (int, f"largest SVG file read, in bytes (default {MAX_BYTES:,})"),
    "max_nodes": (int, f"most XML nodes, and shapes after <use> expansion (default {MAX_NODES:,})"),
    "max_depth": (int, f"deepest nesting of nodes and of <use> references (default {MAX_DEPTH})"),
    "max_elements": (int, f"most elements to arrange (default {MAX_ELEMENTS:,})"),
    "max_points": (int, f"most flattened outline points in a document (default {MAX_POINTS:,})"),
    "max_aspect": (float, f"largest viewBox aspect ratio (default {MAX_ASPECT:g})"),
}


def add_limit_arguments(parser) -> None:
    """The ``--max-*`` options of :class:`SvgLimits` as one argument group of ``parser``."""
    from neuraltex.cli.args import integer, number

    group = parser.add_argument_group("limits of SVG input (raise them for larger files)")
    for name, (kind, text) in ARGUMENTS.items():
        parse = integer(1, 10**12) if kind is int else number(1, 1e9)
        group.add_argument(f"--{name.replace('_', '-')}", dest=name, type=parse,
                           default=getattr(SvgLimits, name), metavar="N", help=text)


def limits_from(args) -> SvgLimits:
    """The :class:`SvgLimits` of parsed ``--max-*`` options (defaults for missing ones)."""
    return SvgLimits(**{k: getattr(args, k) for k in ARGUMENTS if hasattr(args, k)})
