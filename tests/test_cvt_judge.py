"""The real-world judge (cvt/judge.py): copies read back from SVG, references, verdicts."""


from cvt.judge import judge, placements_of, references, svg_of
from cvt.svg import parse_svg

NS = 'xmlns="http://www.w3.org/2000/svg"'


def _exemplar():
    body = '<rect width="60" height="60" fill="#ffe"/>' + "".join(
        f'<g transform="translate({x},{y})"><circle r="4" fill="red"/>'
        f'<circle cx="1" r="1.5" fill="blue"/></g>' for x in (10, 30, 50) for y in (10, 30, 50))
    return parse_svg(f'<svg {NS} viewBox="0 0 60 60">{body}</svg>'.encode(), "auto")


def test_placements_are_read_back_from_the_svg():
    ex = _exemplar()
    placed = [(3, 1.5, -2.0), (0, 60.0, 0.0), (8, 0.0, 0.0)]
    assert placements_of(svg_of(ex, placed, (120, 120)), ex) == placed


def test_the_tiling_passes_and_random_placement_does_not():
    ex = _exemplar()
    r1, r2 = references(ex, (120, 120))
    good = judge(ex, svg_of(ex, r2, (120, 120)), (120, 120))
    assert good["pass"] and good["density"] < 0.01 and good["integrity"] == 1.0
    bad = judge(ex, svg_of(ex, r1, (120, 120)), (120, 120))
    assert not bad["verdict"]["pcf"]
