"""What an element is (cvt/elements.py) and what the background is (cvt/background.py)."""

import numpy as np
import pytest

from cvt.svg import parse_svg, to_svg

NS = 'xmlns="http://www.w3.org/2000/svg"'
INK = 'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"'
SQUARES = "M0 0 H4 V4 H0 Z M10 0 H14 V4 H10 Z M0 10 H4 V14 H0 Z m10 0 h4 v4 h-4 z"


def _svg(body: str, extra: str = "") -> bytes:
    return f'<svg {NS} {extra} viewBox="0 0 40 40">{body}</svg>'.encode()


def test_compound_path_is_split_into_pieces_in_auto_not_in_groups():
    doc = _svg(f'<path d="{SQUARES}" fill="red"/><circle cx="30" cy="30" r="3"/>')
    auto = parse_svg(doc, "auto")
    assert len(auto.elements) == 5 and "split" in auto.note
    boxes = sorted(tuple(e.bbox.round(6)) for e in auto.elements[:4])
    assert boxes[-1] == (10, 10, 14, 14)  # the relative m after z lands where it was drawn
    assert len(parse_svg(doc, "groups").elements) == 2


def test_nested_rings_stay_one_piece():
    ring = "M0 0 H10 V10 H0 Z M3 3 H7 V7 H3 Z"  # a square with a hole
    doc = _svg(f'<path d="{ring} M20 0 H24 V4 H20 Z M30 0 H34 V4 H30 Z" fill-rule="evenodd"/>'
               '<circle cx="30" cy="30" r="2"/>')
    ex = parse_svg(doc, "auto")
    assert sorted(len(e.shapes[0].rings) for e in ex.elements[:3]) == [1, 1, 2]


def test_lone_wrapper_group_is_opened_with_its_transform():
    doc = _svg('<g transform="translate(5,5)" fill="blue"><circle cx="0" cy="0" r="2"/>'
               '<circle cx="10" cy="0" r="2"/><circle cx="20" cy="0" r="2"/></g>')
    ex = parse_svg(doc, "auto")
    assert len(ex.elements) == 3 and "wrapper group(s) opened" in ex.note
    np.testing.assert_allclose(ex.elements[1].bbox, [13, 3, 17, 7], atol=1e-6)
    assert 'fill="blue"' in ex.elements[0].markup  # presentation attributes travel along
    assert len(parse_svg(doc, "groups").elements) == 1


def test_groups_are_kept_and_layers_opened():
    layer = '<g inkscape:groupmode="layer">{}</g>'
    motif = '<g transform="translate({0},{0})"><circle r="2"/><rect width="1" height="1"/></g>'
    doc = _svg(layer.format("".join(motif.format(x) for x in (5, 15, 25))), INK)
    for mode in ("auto", "groups"):
        ex = parse_svg(doc, mode)
        assert len(ex.elements) == 3 and all(len(e.shapes) == 2 for e in ex.elements)
    assert len(parse_svg(doc, "shapes").elements) == 6


def test_canvas_rect_and_ground_layer_are_background():
    doc = _svg('<rect width="40" height="40" fill="#eee"/><circle cx="10" cy="10" r="3"/>'
               '<circle cx="30" cy="20" r="3"/>')
    ex = parse_svg(doc, "auto")
    assert len(ex.background) == 1 and len(ex.elements) == 2
    assert [e.index for e in ex.elements] == [0, 1]
    ground = parse_svg(_svg('<g><rect x="-1" y="-1" width="42" height="42"/></g>'
                            '<circle cx="10" cy="10" r="3"/><circle cx="20" cy="10" r="3"/>'),
                       "groups")
    assert len(ground.background) == 1 and len(ground.elements) == 2


def test_background_is_stretched_or_tiled_in_the_output():
    from cvt.background import backdrop_nodes

    doc = _svg('<defs><pattern id="p" width="4" height="4"><circle r="1"/></pattern></defs>'
               '<rect width="40" height="40" fill="#eee"/><rect width="40" height="40" '
               'fill="url(#p)"/><circle cx="10" cy="10" r="3"/>', 'style="background:#123"')
    ex = parse_svg(doc, "auto")
    assert len(ex.background) == 3  # root colour, flat rect, pattern rect
    nodes = backdrop_nodes(ex, (0, 0, 80, 120))
    stretched = [n for n in nodes if "scale(2,3)" in n.get("transform")]
    assert len(stretched) == 2 and len(nodes) == 2 + 2 * 3  # the pattern rect tiled 2 x 3
    text = to_svg(ex, [(0, 5, 5)], (80, 120), nodes)
    assert text.index("#123") < text.index("url(#p)") < text.index("translate(5,5)")


@pytest.mark.parametrize("mode", ["auto", "shapes", "groups"])
def test_only_background_leaves_no_elements(mode):
    ex = parse_svg(_svg('<rect width="40" height="40" fill="red"/>'), mode)
    assert ex.elements == [] and len(ex.background) == 1
