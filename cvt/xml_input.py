"""Untrusted XML bytes -> an element tree, defensively: bounded file size, node count and
nesting depth; any encoding Python knows (Shift_JIS, EUC-JP, UTF-16...) decoded here, because
the XML parser itself only knows a few; no DTD, hence no entities (no XXE, no billion laughs)."""

from __future__ import annotations

import codecs
import io
import re
import xml.etree.ElementTree as ET

from cvt.limits import SvgLimits
from neuraltex.errors import InputError, one_line

_DECL = re.compile(rb"^\s*<\?xml[^>]*?encoding\s*=\s*[\"']([^\"']{1,40})[\"']")
_DECL_TEXT = re.compile(r"^\s*<\?xml[^>]*\?>")
_BOMS = ((codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
         (codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF16_LE, "utf-16"),
         (codecs.BOM_UTF16_BE, "utf-16"))


def decode(data: bytes) -> str:
    """The document as text: a byte-order mark wins, then the XML declaration's encoding,
    else UTF-8 (as XML says). InputError for an unknown encoding or bytes that do not fit it."""
    encoding = next((enc for bom, enc in _BOMS if data.startswith(bom)), None)
    if encoding is None:
        m = _DECL.match(data)
        encoding = m.group(1).decode("ascii", "replace") if m else "utf-8"
    try:
        codecs.lookup(encoding)
        return data.decode(encoding)
    except LookupError:
        raise InputError(f"unknown text encoding {encoding!r} in the XML declaration") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"the file is not valid {encoding} text ({one_line(exc)[:80]})") from None


def read_xml(data: bytes, limits: SvgLimits) -> tuple[ET.Element, dict[str, str]]:
    """(root, {prefix: namespace uri}) of untrusted XML ``data``; InputError on anything bad."""
    limits.check(len(data), "max_bytes", "SVG file size in bytes")
    text = decode(data)
    if "<!DOCTYPE" in text.upper() or "<!ENTITY" in text.upper():
        raise InputError("SVG with DOCTYPE/ENTITY declarations is not accepted (entity expansion)")
    utf8 = _DECL_TEXT.sub("", text, count=1).encode("utf-8")
    namespaces: dict[str, str] = {}
    root, count, depth = None, 0, 0
    try:
        for ev, item in ET.iterparse(io.BytesIO(utf8), events=("start", "end", "start-ns")):
            if ev == "start-ns":
                namespaces.setdefault(item[0], item[1])
            elif ev == "start":
                depth += 1
                limits.check(depth, "max_depth", "SVG nesting depth")
            else:
                depth -= 1
                count += 1
                root = item
                limits.check(count, "max_nodes", "SVG node count")
    except ET.ParseError as exc:
        raise InputError(f"malformed SVG/XML: {exc}") from None
    return root, namespaces
