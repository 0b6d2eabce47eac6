"""SVG in/out: geometry survives a round trip, translations are exact, bad input is refused."""

from pathlib import Path

import numpy as np
import pytest

from cvt.svg import load_svg, parse_svg, to_svg
from neuraltex.errors import InputError

EXEMPLARS = sorted((Path(__file__).resolve().parents[1] / "cvt" / "exemplars").glob("*.svg"))


def _rings(ex):
    return [[r for s in e.shapes for r in s.rings] for e in ex.elements]


def test_ships_at_least_12_exemplars():
    assert len(EXEMPLARS) >= 12


@pytest.mark.parametrize("path", EXEMPLARS, ids=lambda p: p.stem)
def test_parse_write_reproduces_geometry(path):
    ex = load_svg(path)
    out = parse_svg(to_svg(ex, [(e.index, 0.0, 0.0) for e in ex.elements], ex.viewbox[2:]).encode())
    assert out.viewbox == ex.viewbox
    assert len(out.elements) == len(ex.elements)
    for a, b in zip(_rings(ex), _rings(out), strict=True):
        assert len(a) == len(b)
        for ra, rb in zip(a, b, strict=True):
            np.testing.assert_allclose(ra, rb, atol=1e-6)


def test_translated_copies_are_exact():
    ex = load_svg(EXEMPLARS[0].parent / "gradient_blossoms.svg")
    moves = [(3, 10.5, -7.25), (3, 100.0, 50.0), (0, -1.0, 2.0)]
    text = to_svg(ex, moves, (400.0, 400.0))
    out = parse_svg(text.encode())
    assert len(out.elements) == 3
    assert 'id="glow"' in text  # the referenced gradient travels along in <defs>
    for (idx, dx, dy), e in zip(moves, out.elements, strict=True):
        for ra, rb in zip(_rings(ex)[idx], [r for s in e.shapes for r in s.rings], strict=True):
            np.testing.assert_allclose(ra + [dx, dy], rb, atol=1e-6)


def test_ids_inside_copies_stay_unique():
    svg = (b'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
           b'viewBox="0 0 10 10"><g id="a"><path id="p" d="M0 0 L5 0 L5 5 Z"/>'
           b'<use xlink:href="#p" x="1"/></g></svg>')
    ex = parse_svg(svg)
    text = to_svg(ex, [(0, 0, 0), (0, 3, 3)], (10, 10))
    assert text.count('id="p-c0"') == 1 and text.count('id="p-c1"') == 1
    assert "#p-c1" in text
    assert len(parse_svg(text.encode()).elements) == 2


def test_groups_are_one_element_and_use_is_expanded():
    ex = load_svg(EXEMPLARS[0].parent / "gradient_blossoms.svg")
    assert all(len(e.shapes) == 5 for e in ex.elements)  # five <use> petals per group


@pytest.mark.parametrize("data, msg", [
    (b"<svg xmlns='http://www.w3.org/2000/svg'><g>", "malformed"),
    (b"not xml at all", "malformed"),
    (b"<html/>", "not an SVG"),
    (b"<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 10 10'><g/></svg>", "no drawable"),
    (b"<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 10 10'><text>hi</text></svg>",
     "only text"),
    (b"<svg xmlns='http://www.w3.org/2000/svg' viewBox='0 0 1e30 10'><rect width='1' "
     b"height='1'/></svg>", "absurd"),
    (b"<?xml version='1.0'?><!DOCTYPE svg [<!ENTITY a 'aaaa'><!ENTITY b '&a;&a;&a;'>]>"
     b"<svg xmlns='http://www.w3.org/2000/svg'>&b;</svg>", "DOCTYPE"),
])
def test_bad_input_is_refused(data, msg):
    with pytest.raises(InputError, match=msg):
        parse_svg(data)


def test_transforms_are_applied_to_every_shape_kind():
    svg = (b'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
           b'<rect x="-5" y="-2" width="10" height="4" rx="1" transform="translate(50,40) '
           b'rotate(90)"/><g transform="translate(10,0)"><circle cx="5" cy="5" r="2"/></g></svg>')
    ex = parse_svg(svg)
    np.testing.assert_allclose(ex.elements[0].bbox, [48, 35, 52, 45], atol=1e-6)
    np.testing.assert_allclose(ex.elements[1].bbox, [13, 3, 17, 7], atol=1e-6)


def test_invisible_and_degenerate_nodes_are_not_elements():
    svg = (b'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 50 50">'
           b'<circle cx="10" cy="10" r="3" display="none"/><g style="display: none"><rect '
           b'width="4" height="4"/></g><circle cx="5" cy="5" r="0"/><path d="M0 0"/>'
           b'<rect width="5" height="5" transform="matrix(0 0 0 0 0 0)"/>'
           b'<circle cx="30" cy="30" r="3"/></svg>')
    assert len(parse_svg(svg).elements) == 1
