"""The hostile and odd SVG files of the reliability corpus (tests/corpus/svg/) and the ``cvt``
command lines run over them: ``<use>`` cycles and expansion bombs, deep nesting, absurd
coordinates and sizes, odd encodings and units, external references (local files, URLs, XML
entities), huge and many elements. Used by scripts/make_corpus.py; every file is small.

Each writer returns {file name: expectation}: "ok" (the command succeeds) or "error" (one line,
exit code 2). External references are "ok": they are dropped with a warning, never followed.
"""

from __future__ import annotations

import gzip

import numpy as np
from PIL import Image

HEAD = '<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"'
VB = f'{HEAD} width="100" height="100" viewBox="0 0 100 100">'
SECRET = "secret.png"  # a pure red picture next to the SVGs: it must never show up in a render


def _dots(n: int = 6, r: float = 5.0, seed: int = 0, extra: str = "") -> str:
    """``n`` circles scattered over the 100 x 100 canvas."""
    xy = np.random.default_rng(seed).uniform(10, 90, (n, 2))
    return "".join(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:g}" fill="#3a6"{extra}/>'
                   for x, y in xy)


def _doc(body: str, head: str = VB) -> str:
    return f"{head}{body}</svg>"


def _grid(n: int, r: float) -> str:
    """An n x n grid of small circles over the 100 x 100 canvas."""
    step = 100 / n
    return "".join(f'<circle cx="{(i + 0.5) * step:.2f}" cy="{(j + 0.5) * step:.2f}" r="{r:g}"/>'
                   for i in range(n) for j in range(n))


def _use_chain(depth: int, fan: int = 10) -> str:
    """<defs> where each level uses the previous one ``fan`` times: fan**depth circles."""
    levels = ['<g id="l0"><circle cx="1" cy="1" r="1"/></g>']
    for k in range(1, depth + 1):
        uses = "".join(f'<use href="#l{k - 1}" x="{i}"/>' for i in range(fan))
        levels.append(f'<g id="l{k}">{uses}</g>')
    return f"<defs>{''.join(levels)}</defs><use href=\"#l{depth}\"/>" + _dots(3)


def structure_files() -> dict[str, tuple[str, str | bytes]]:
    """{name: (expectation, content)}: the document's structure is hostile."""
    nested = "<g>" * 3000 + '<circle cx="50" cy="50" r="9"/>' + "</g>" * 3000
    return {
        "valid.svg": ("ok", _doc(_dots())),
        "use_self.svg": ("error", _doc('<use id="u" href="#u"/>' + _dots())),
        "use_self_xlink.svg": ("error", _doc('<g id="g"><use xlink:href="#g"/></g>' + _dots())),
        "use_mutual.svg": ("error", _doc('<g id="a"><use href="#b"/></g>'
                                         '<g id="b"><use href="#a"/></g>' + _dots())),
        "use_defs_cycle.svg": ("error", _doc('<defs><g id="a"><use href="#b"/></g>'
                                             '<g id="b"><use href="#c"/></g><g id="c">'
                                             '<use href="#a"/></g></defs><use href="#a"/>'
                                             + _dots())),
        "use_chain_1e7.svg": ("error", _doc(_use_chain(7))),
        "use_chain_1e4.svg": ("error", _doc(_use_chain(4))),
        "use_chain_100.svg": ("ok", _doc(_use_chain(2))),
        "use_missing.svg": ("ok", _doc('<use href="#nothing"/>' + _dots())),
        "nested_3000.svg": ("error", _doc(nested)),
        "nested_3000_in_defs.svg": ("error", _doc(f"<defs>{nested}</defs>" + _dots())),
        "nested_50.svg": ("ok", _doc("<g>" * 50 + _dots() + "</g>" * 50)),
        "empty_svg.svg": ("error", _doc("")),
        "not_svg_root.svg": ("error", "<html><svg/></html>"),
        "truncated.svg": ("error", _doc(_dots())[:150]),
        "empty_file.svg": ("error", b""),
        "binary.svg": ("error", bytes(range(256)) * 4),
        "only_text.svg": ("error", _doc('<text x="10" y="50">hello</text>')),
        "only_image.svg": ("error", _doc(f'<image href="{SECRET}" width="100" height="100"/>')),
        "display_none.svg": ("error", _doc(_dots(extra=' display="none"'))),
        "gradient_href_cycle.svg": ("ok", _doc(
            '<defs><linearGradient id="a" href="#b"/><linearGradient id="b" xlink:href="#a">'
            '<stop offset="0" stop-color="red"/></linearGradient></defs>'
            '<rect width="20" height="20" fill="url(#a)"/>' + _dots())),
        "pattern_self.svg": ("ok", _doc(
            '<pattern id="p" width="10" height="10" patternUnits="userSpaceOnUse">'
            '<rect width="5" height="5" fill="url(#p)"/></pattern>'
            '<rect width="30" height="30" fill="url(#p)"/>' + _dots())),
        "clip_self.svg": ("ok", _doc('<clipPath id="c"><rect width="9" height="9" '
                                     'clip-path="url(#c)"/></clipPath>'
                                     '<rect width="30" height="30" clip-path="url(#c)"/>'
                                     + _dots())),
        "svgz.svg": ("error", gzip.compress(_doc(_dots()).encode(), mtime=0)),
        "ids_clash.svg": ("ok", _doc('<g id="a">' + _dots(3) + '</g><g id="a">' + _dots(3, seed=1)
                                     + "</g>")),
    }


def geometry_files() -> dict[str, tuple[str, str | bytes]]:
    """{name: (expectation, content)}: absurd numbers, sizes and units."""
    big_path = "M0 0" + "h1v1" * 80_000  # 160,000 points
    spiral = "M50 50 " + " ".join(f"Q{50 + i % 40} {50 - i % 30} {50 + i % 45} {50 + i % 35}"
                                  for i in range(12_000))  # 192,000 points
    return {
        "coords_1e308.svg": ("error", _doc('<circle cx="1e308" cy="1e308" r="1e308"/>')),
        "coords_1e308_mixed.svg": ("ok", _doc('<circle cx="1e308" cy="5" r="3"/>' + _dots())),
        "path_1e308.svg": ("error", _doc('<path d="M0 0 L1e308 1e308 L0 1e308 Z"/>')),
        "path_inf.svg": ("ok", _doc('<path d="M0 0 L1e999 5 L0 9 Z"/>' + _dots())),
        "transform_1e300.svg": ("error", _doc(f'<g transform="scale(1e300)">{_dots()}</g>')),
        "transform_singular.svg": ("ok", _doc(f'<g transform="scale(0)">{_dots(3)}</g>'
                                              + _dots())),
        "element_100x.svg": ("ok", _doc('<rect x="-5000" y="-5000" width="10000" height="10000"'
                                        ' fill="#eee"/>' + _dots())),
        "element_300x.svg": ("ok", _doc('<rect x="0" y="0" width="30000" height="30000"/>'
                                        + _dots())),
        "element_1e4x.svg": ("ok", _doc('<circle cx="50" cy="50" r="1000000"/>' + _dots())),
        "element_1e4x_alone.svg": ("error", _doc('<circle cx="50" cy="50" r="1000000"/>')),
        "element_far_away.svg": ("ok", _doc('<circle cx="1e6" cy="1e6" r="5"/>' + _dots())),
        "stroke_huge.svg": ("ok", _doc('<circle cx="50" cy="50" r="5" fill="none" stroke="red"'
                                       ' stroke-width="1e6"/>' + _dots())),
        "stroke_1e300.svg": ("ok", _doc('<line x1="0" y1="0" x2="9" y2="9" stroke="red"'
                                        ' stroke-width="1e300"/>' + _dots())),
        "tiny_viewbox.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="0 0 1e-6 1e-6">')),
        "tiny_viewbox_scaled.svg": ("ok", _doc(f'<g transform="scale(1e-8)">{_dots()}</g>',
                                               f'{HEAD} viewBox="0 0 1e-6 1e-6">')),
        "viewbox_offset.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="1e6 1e6 100 100">')),
        "viewbox_offset_1e300.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="1e300 0 100 100">')),
        "viewbox_zero.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="0 0 0 100">')),
        "viewbox_negative.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="0 0 -100 100">')),
        "viewbox_nan.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="0 0 nan 100">')),
        "viewbox_words.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="a b c d">')),
        "viewbox_aspect_1e4.svg": ("error", _doc(_dots(), f'{HEAD} viewBox="0 0 100 0.01">')),
        "no_viewbox_no_size.svg": ("error", _doc(_dots(), f"{HEAD}>")),
        "size_only.svg": ("ok", _doc(_dots(), f'{HEAD} width="100" height="100">')),
        "size_mm.svg": ("ok", _doc(_dots(), f'{HEAD} width="100mm" height="100mm" '
                                   'viewBox="0 0 100 100">')),
        "percent_size.svg": ("ok", _doc(_dots(), f'{HEAD} width="100%" height="100%" '
                                        'viewBox="0 0 100 100">')),
        "percent_units.svg": ("ok", _doc(
            '<circle cx="20%" cy="30%" r="5%"/><rect x="50%" y="50%" width="10%" height="10%"/>'
            + _dots(), f'{HEAD} width="100%" height="100%" viewBox="0 0 100 100">')),
        "percent_no_viewbox.svg": ("error", _doc('<circle cx="20%" cy="30%" r="5%"/>',
                                                 f'{HEAD} width="100%" height="100%">')),
        "percent_huge.svg": ("ok", _doc('<circle cx="1e300%" cy="30%" r="1e300%"/>' + _dots())),
        "em_units.svg": ("ok", _doc('<circle cx="2em" cy="3em" r="1em"/>' + _dots())),
        "huge_path.svg": ("error", _doc(f'<path d="{big_path}" fill="none" stroke="black"/>')),
        "huge_curve_path.svg": ("error", _doc(f'<path d="{spiral}" fill="#a33"/>')),
        "bad_path.svg": ("ok", _doc('<path d="M 0 0 L x y Q"/>' + _dots())),
        "small_4900.svg": ("error", _doc(_grid(70, 0.5))),
        "small_900.svg": ("error", _doc(_grid(30, 0.8))),
        "small_400.svg": ("ok", _doc(_grid(20, 1.0))),
    }


def reference_files() -> dict[str, tuple[str, str | bytes]]:
    """{name: (expectation, content)}: references out of the document, never to be followed."""
    img = f'<image href="{SECRET}" x="0" y="0" width="100" height="100"/>'
    ximg = f'<image xlink:href="{SECRET}" x="0" y="0" width="100" height="100"/>'
    xxe = ('<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY x SYSTEM "file:///etc/hostname">]>'
           + _doc('<text x="5" y="50">&x;</text>' + _dots()))
    laughs = ('<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY a "aaaaaaaaaa">'
              + "".join(f'<!ENTITY {c} "{("&" + p + ";") * 10}">'
                        for p, c in zip("abcdefgh", "bcdefghi", strict=True))
              + "]>" + _doc('<text x="5" y="50">&i;</text>' + _dots()))
    return {
        "image_local.svg": ("ok", _doc(img + _dots())),
        "image_xlink_local.svg": ("ok", _doc(ximg + _dots())),
        "image_absolute.svg": ("ok", _doc('<image href="/etc/hostname" width="100" height="100"/>'
                                          + _dots())),
        "image_file_url.svg": ("ok", _doc('<image href="file:///etc/passwd" width="9" height="9"/>'
                                          + _dots())),
        "image_http.svg": ("ok", _doc('<image href="http://example.com/x.png" width="9" '
                                      'height="9"/>' + _dots())),
        "image_in_group.svg": ("ok", _doc(f"<g>{img}{_dots(2)}</g>" + _dots())),
        "image_in_pattern.svg": ("ok", _doc(
            f'<defs><pattern id="p" width="100" height="100" patternUnits="userSpaceOnUse">{img}'
            '</pattern></defs><rect width="50" height="50" fill="url(#p)"/>' + _dots())),
        "feimage.svg": ("ok", _doc(
            f'<defs><filter id="f"><feImage href="{SECRET}"/></filter></defs>'
            '<rect width="60" height="60" filter="url(#f)"/>' + _dots())),
        "feimage_xlink.svg": ("ok", _doc(
            f'<filter id="f"><feImage xlink:href="{SECRET}" width="100" height="100"/></filter>'
            '<g filter="url(#f)">' + _dots(3) + "</g>" + _dots())),
        "use_external.svg": ("ok", _doc('<use href="other.svg#x"/><use href="/etc/x.svg#y"/>'
                                        + _dots())),
        "fill_url_external.svg": ("ok", _doc('<rect width="20" height="20" '
                                             'fill="url(other.svg#g)"/>' + _dots())),
        "css_import.svg": ("ok", _doc('<style>@import url("/etc/x.css"); rect {fill: '
                                      f'url({SECRET})}}</style><rect width="9" height="9"/>'
                                      + _dots())),
        "style_attr_url.svg": ("ok", _doc(f'<rect width="30" height="30" style="fill: url('
                                          f"'{SECRET}')\"/>" + _dots())),
        "image_data_svg.svg": ("ok", _doc(
            '<image width="50" height="50" href="data:image/svg+xml;utf8,'
            f"&lt;svg xmlns='http://www.w3.org/2000/svg'&gt;&lt;image href='{SECRET}' "
            "width='50' height='50'/&gt;&lt;/svg&gt;\"/>" + _dots())),
        "xxe.svg": ("error", xxe),
        "billion_laughs.svg": ("error", laughs),
        "doctype_public.svg": ("error", '<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" '
                               '"http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd">'
                               + _doc(_dots())),
        "xinclude.svg": ("ok", _doc('<xi:include xmlns:xi="http://www.w3.org/2001/XInclude" '
                                    'href="/etc/hostname" parse="text"/>' + _dots())),
        "stylesheet_pi.svg": ("ok", f'<?xml-stylesheet href="{SECRET}" type="text/css"?>'
                              + _doc(_dots())),
    }


def encoding_files() -> dict[str, tuple[str, str | bytes]]:
    """{name: (expectation, content as bytes)}: declared and real encodings."""
    body = _doc("<!-- 模様 -->" + _dots())
    return {
        "shift_jis.svg": ("ok", ('<?xml version="1.0" encoding="Shift_JIS"?>' + body)
                          .encode("shift_jis")),
        "euc_jp.svg": ("ok", ('<?xml version="1.0" encoding="EUC-JP"?>' + body).encode("euc_jp")),
        "unknown_encoding.svg": ("error", ('<?xml version="1.0" encoding="x-klingon"?>' + body)
                                 .encode()),
        "encoding_mismatch.svg": ("ok", ('<?xml version="1.0" encoding="UTF-8"?>' + body)
                                  .encode("utf-16")),
        "utf16_bom.svg": ("ok", ('<?xml version="1.0" encoding="UTF-16"?>' + body)
                          .encode("utf-16")),
        "latin1.svg": ("ok", ('<?xml version="1.0" encoding="ISO-8859-1"?>'
                              + _doc("<!-- dé -->" + _dots())).encode("latin-1")),
        "latin1_undeclared.svg": ("error", _doc("<!-- dé -->" + _dots()).encode("latin-1")),
        "utf8_bom.svg": ("ok", b"\xef\xbb\xbf" + body.encode()),
    }


def svg_files(d) -> dict[str, str]:
    """Write every SVG of the corpus (and the secret picture) into ``d``."""
    d.mkdir(parents=True, exist_ok=True)
    Image.new("RGB", (8, 8), (255, 0, 0)).save(d / SECRET)
    out = {}
    for group in (structure_files, geometry_files, reference_files, encoding_files):
        for name, (expect, content) in group().items():
            data = content.encode() if isinstance(content, str) else content
            (d / name).write_bytes(data)
            out[name] = expect
    return out


SVG = "{c}/svg"
CURVE = "{c}/svg/curve.svg"


def curve_file(d) -> None:
    """A small valid curve exemplar (long crossing strokes) for ``cvt autocomplete``."""
    lines = "".join(f'<path d="M{x} 0 C{x + 30} 30 {x - 30} 70 {x} 100" fill="none" '
                    'stroke="#222" stroke-width="1.5"/>' for x in range(10, 100, 20))
    (d / "curve.svg").write_text(_doc(lines + '<path d="M0 50 L100 50" fill="none" '
                                      'stroke="#222" stroke-width="1.5"/>'))
