"""Writing SVG text: the document around the elements, short numbers, hex colours. Shared by
neuraltex's SVG writers (:func:`neuraltex.vectorize.to_svg`, :func:`neuraltex.overlay.
ellipses_svg`); cvt keeps the original markup of its exemplars and writes its own."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def document(width: float, height: float, body: Sequence[str], defs: Sequence[str] = ()) -> str:
    """An SVG document of ``width`` x ``height`` user units (viewBox from the origin) holding
    ``body``, with a ``<defs>`` block when ``defs`` is not empty."""
    head = (f'<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{number(width)}" '
            f'height="{number(height)}" viewBox="0 0 {number(width)} {number(height)}">')
    defs_text = ["<defs>", *defs, "</defs>"] if defs else []
    return "\n".join([head, *defs_text, *body, "</svg>"]) + "\n"


def number(v: float) -> str:
    """At most two decimals, no trailing zeros: 1.50 -> "1.5", 2.0 -> "2"."""
    return f"{v:.2f}".rstrip("0").rstrip(".")


def hex_colour(c: np.ndarray) -> str:
    """RGB (3,) in [0, 1] -> "#rrggbb"."""
    r, g, b = (int(round(float(v) * 255)) for v in np.clip(c, 0, 1))
    return f"#{r:02x}{g:02x}{b:02x}"
