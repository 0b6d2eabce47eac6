"""External references in SVG: never followed, never passed on.

An SVG can point out of itself: ``<image href="/etc/passwd">``, ``<feImage xlink:href=...>``,
``<use href="other.svg#x">``, ``fill="url(file.svg#g)"``, CSS ``@import`` and ``url(...)``.
A renderer (resvg) would read such files and draw them into a preview, which discloses files
when a service renders user SVGs. Every link that is not to an id inside the document
(``#id``) or an inline raster picture (``data:image/png`` and the like) is removed, in parsed
input and again in any SVG text right before it is rasterized. XML entities never get this far:
documents with a DOCTYPE are refused (cvt.svg).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

_INLINE = re.compile(r"\s*(#|data:image/(png|jpeg|jpg|gif|webp)[;,])", re.I)
_CSS_URL = re.compile(r"url\(\s*(['\"]?)(?!\s*#)[^)]*\)", re.I)
_CSS_IMPORT = re.compile(r"@import[^;]*;?", re.I)


def is_internal(link: str) -> bool:
    """Whether ``link`` stays inside the document: ``#id`` or an inline raster picture."""
    return bool(_INLINE.match(link))


def _is_href(key: str) -> bool:
    return key.rsplit("}", 1)[-1] == "href"


def clean_css(text: str) -> tuple[str, int]:
    """CSS with its ``@import`` rules and ``url(...)`` to anything but ``#id`` removed (url
    becomes ``none``), and how many were removed."""
    text, n_import = _CSS_IMPORT.subn("", text)
    text, n_url = _CSS_URL.subn("none", text)
    return text, n_import + n_url


def strip_external(root: ET.Element) -> int:
    """Remove every external reference under ``root`` in place; returns how many."""
    removed = 0
    for node in root.iter():
        for key, value in list(node.attrib.items()):
            if _is_href(key) and not is_internal(value):
                del node.attrib[key]
                removed += 1
            elif "url(" in value.lower():
                clean, n = clean_css(value)
                if n:
                    node.set(key, clean)
                    removed += n
        if isinstance(node.tag, str) and node.tag.endswith("style") and node.text:
            node.text, n = clean_css(node.text)
            removed += n
    return removed


def safe_svg_text(text: str) -> str:
    """SVG text without external references, for a rasterizer; text that does not parse as
    XML (or declares entities) is refused with ValueError rather than handed on."""
    if "<!DOCTYPE" in text.upper() or "<!ENTITY" in text.upper():
        raise ValueError("SVG with DOCTYPE/ENTITY declarations is not rendered")
    root = ET.fromstring(text)
    if not strip_external(root):
        return text
    return ET.tostring(root, encoding="unicode")
