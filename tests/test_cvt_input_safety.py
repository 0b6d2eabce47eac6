"""Hostile SVG input: encodings, <use> cycles and bombs, external references, budgets, huge
geometry, bounded renders; and --help text for every cvt argument. (The corpus test runs the
CLIs over many more files; these pin the pieces.)"""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from PIL import Image

from cvt.limits import SvgLimits
from cvt.raster import png_bytes
from cvt.references import is_internal, strip_external
from cvt.sampling import _inside, element_candidates
from cvt.svg import parse_svg
from cvt.use_expansion import expanded_size
from cvt.xml_input import decode
from neuraltex.errors import InputError

HEAD = '<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
DOTS = '<circle cx="20" cy="20" r="5"/><circle cx="70" cy="60" r="8"/>'


def svg(body: str, attrs: str = 'width="100" height="100" viewBox="0 0 100 100"') -> bytes:
    return f"{HEAD}{attrs}>{body}</svg>".encode()


def test_any_python_encoding_is_decoded_and_unknown_ones_are_one_line():
    text = '<?xml version="1.0" encoding="Shift_JIS"?>' + svg("<!-- 模様 -->" + DOTS).decode()
    assert len(parse_svg(text.encode("shift_jis")).elements) == 2
    assert decode("<a/>".encode("utf-16")) == decode("<a/>".encode("utf-8-sig")) == "<a/>"
    for data in (b'<?xml version="1.0" encoding="x-klingon"?><svg/>',
                 b'<?xml version="1.0" encoding="zlib"?><svg/>', "é".encode("latin-1")):
        with pytest.raises(InputError):
            decode(data)


def test_doctype_is_refused_even_in_utf16():
    data = ('<!DOCTYPE svg [<!ENTITY x "y">]>' + svg(DOTS).decode()).encode("utf-16")
    with pytest.raises(InputError, match="DOCTYPE"):
        parse_svg(data)


@pytest.mark.parametrize("body", [
    '<use id="u" href="#u"/>',
    '<g id="a"><use href="#b"/></g><g id="b"><use xlink:href="#a"/></g>',
    '<defs><g id="a"><g><use href="#c"/></g></g><g id="c"><use href="#a"/></g></defs>'
    '<use href="#a"/>',
])
def test_use_cycles_are_refused(body):
    with pytest.raises(InputError, match="cycle"):
        parse_svg(svg(body + DOTS))


def test_use_expansion_is_counted_without_expanding():
    levels = ['<g id="l0"><circle r="1"/></g>'] + [
        f'<g id="l{k}">' + f'<use href="#l{k - 1}"/>' * 10 + "</g>" for k in range(1, 8)]
    root = ET.fromstring(svg(f"<defs>{''.join(levels)}</defs>").decode())
    by_id = {n.get("id"): n for n in root.iter() if n.get("id")}
    top = ET.fromstring('<use xmlns="http://www.w3.org/2000/svg" href="#l2"/>')
    assert expanded_size(top, by_id, SvgLimits()) == 1 + 11 + 10 * (11 + 10 * 2)  # 321 nodes
    top.set("href", "#l7")  # 10^7 circles
    with pytest.raises(InputError, match="--max-nodes"):
        expanded_size(top, by_id, SvgLimits())


def test_nesting_depth_is_bounded_with_an_option():
    deep = svg("<g>" * 150 + DOTS + "</g>" * 150)
    with pytest.raises(InputError, match="--max-depth"):
        parse_svg(deep)
    assert len(parse_svg(deep, limits=SvgLimits(max_depth=200)).elements) == 1


def test_element_and_point_budgets_name_their_option():
    with pytest.raises(InputError, match="--max-elements"):
        parse_svg(svg(DOTS), limits=SvgLimits(max_elements=1))
    with pytest.raises(InputError, match="--max-points"):
        parse_svg(svg(DOTS), limits=SvgLimits(max_points=50))


def test_external_references_are_removed_and_counted():
    root = ET.fromstring(svg(
        '<image href="/etc/passwd"/><image xlink:href="data:image/png;base64,AA"/>'
        '<use href="#a"/><use href="other.svg#b"/><rect style="fill: url(secret.png)"/>'
        '<rect fill="url(#grad)"/><style>@import url(x.css); a {fill: url(y.svg#p)}</style>'
    ).decode())
    assert strip_external(root) == 5
    hrefs = [v for n in root.iter() for k, v in n.attrib.items() if k.endswith("href")]
    assert hrefs == ["data:image/png;base64,AA", "#a"]
    text = ET.tostring(root, encoding="unicode")
    assert "url(#grad)" in text and "secret" not in text and "@import" not in text
    assert is_internal("#x") and not is_internal("data:image/svg+xml,<svg/>")


def test_renders_never_show_a_referenced_local_file(tmp_path):
    import resvg_py

    secret = tmp_path / "secret.png"
    Image.new("RGB", (4, 4), (255, 0, 0)).save(secret)
    text = svg(f'<image href="{secret}" width="100" height="100"/>').decode()
    direct = resvg_py.svg_to_bytes(svg_string=text)  # what resvg alone does: reads the file

    def red(png: bytes) -> bool:
        rgb = np.asarray(Image.open(io.BytesIO(bytes(png))).convert("RGB")).astype(int)
        return bool(((rgb[..., 0] > 240) & (rgb[..., 1] < 16) & (rgb[..., 2] < 16)).any())

    assert red(direct)
    assert not red(png_bytes(text))


def test_renders_are_bounded_and_read_physical_units():
    big = Image.open(io.BytesIO(png_bytes(svg(DOTS, 'width="1e6" height="5e5"').decode())))
    tiny = Image.open(io.BytesIO(png_bytes(svg(DOTS, 'width="1e-6" height="1e-6"').decode())))
    mm = Image.open(io.BytesIO(png_bytes(svg(DOTS, 'width="100mm" height="50mm" '
                                             'viewBox="0 0 100 50"').decode())))
    assert big.size == (4096, 2048) and tiny.size == (16, 16) and mm.size == (378, 189)


def test_huge_and_far_geometry_is_cut_or_dropped():
    ex = parse_svg(svg('<circle cx="50" cy="50" r="1e6" fill="#eee"/>'
                       '<circle cx="1e308" cy="5" r="3"/>' + DOTS))
    assert len(ex.elements) == 2 and len(ex.background) == 1  # the huge disc is background
    assert any("dropped 1 shape" in w for w in ex.warnings)
    el = ex.background[0]
    cand = element_candidates(el, 5.0, np.random.default_rng(0), np.array([-100, -100, 200, 200]))
    assert len(cand) < 50_000  # the grid covers the region, not the 2e6-wide disc


def test_nothing_on_the_canvas_is_one_line():
    with pytest.raises(InputError, match="no element is on the canvas"):
        parse_svg(svg(DOTS, 'viewBox="1e6 1e6 100 100"'))


def test_chunked_fill_test_matches_one_block(monkeypatch):
    from cvt import sampling

    ex = parse_svg(svg('<path d="M10 10 L90 15 L50 90 Z M40 40 L60 40 L50 60 Z" '
                       'fill-rule="evenodd"/>' + DOTS))
    shape = ex.elements[0].shapes[0]
    pts = np.random.default_rng(0).uniform(0, 100, (2000, 2))
    whole = _inside(pts, shape)
    monkeypatch.setattr(sampling, "CHUNK", 7)  # one point per block
    assert (sampling._inside(pts, shape) == whole).all() and 0 < whole.sum() < len(pts)


def test_every_cvt_argument_has_help_and_every_command_a_description():
    from cvt.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, p in sub.choices.items():
        assert p.description, name
        for action in p._actions:
            assert action.help, f"cvt {name} {action.dest}"
