"""Shaped output (cvt/domain.py) and the pattern options on the command line."""

import numpy as np
import pytest

from cvt.cli import main
from cvt.domain import Domain
from cvt.svg import load_svg
from neuraltex.errors import InputError

NS = 'xmlns="http://www.w3.org/2000/svg"'


def _file(tmp_path, name: str, body: str, box: str = "0 0 100 100"):
    p = tmp_path / name
    p.write_text(f'<svg {NS} viewBox="{box}">{body}</svg>')
    return p


def test_domain_inside_test_area_and_fit(tmp_path):
    ring = "M0,0 H10 V10 H0 Z M3,3 H7 V7 H3 Z"  # a square frame (even-odd hole)
    dom = Domain.from_svg(_file(tmp_path, "d.svg", f'<path d="{ring}" fill-rule="evenodd"/>'))
    assert dom.contains(np.array([[1, 1], [5, 5], [11, 5]])).tolist() == [True, False, False]
    assert dom.area == pytest.approx(84, rel=0.02)
    fit = dom.fitted((0, 0, 200, 100))
    assert np.allclose(fit.bounds, (50, 0, 150, 100)) and fit.area == pytest.approx(8400, rel=0.02)


@pytest.mark.parametrize("body, message", [
    ('<path d="M0,0 L10,10 L10,0 L0,10 Z"/>', "crosses itself"),
    ('<path d="M0,0 L10,0 L10,10" fill="none" stroke="black"/>', "not closed"),
    ('<rect width="0" height="5"/>', "no"),
])
def test_bad_domains_are_input_errors(tmp_path, body, message):
    with pytest.raises(InputError, match=message):
        Domain.from_svg(_file(tmp_path, "d.svg", body))


def _dots(tmp_path):
    rng = np.random.default_rng(0)
    body = '<rect width="100" height="100" fill="#def"/>' + "".join(
        f'<g transform="translate({x:.1f},{y:.1f})"><circle r="3" fill="red"/>'
        f'<circle r="1" fill="blue"/></g>' for x, y in rng.uniform(5, 95, (14, 2)))
    return _file(tmp_path, "dots.svg", body)


def test_cli_domain_fills_the_shape_only(tmp_path, capsys):
    star = _file(tmp_path, "disc.svg", '<circle cx="50" cy="50" r="50"/>')
    out = tmp_path / "o.svg"
    assert main(["synthesize", str(_dots(tmp_path)), "-o", str(out), "--scale", "2",
                 "--levels", "1", "--iterations", "2", "--quiet", "--domain", str(star)]) == 0
    res = load_svg(out, "groups")
    c = np.stack([(e.bbox[:2] + e.bbox[2:]) / 2 for e in res.elements])
    assert len(c) >= 20  # about 14 x the disc's share of 4 exemplars
    assert (np.linalg.norm(c - 100, axis=1) < 100 + 4).all()  # every copy touches the disc
    assert "cvt-clip" in out.read_text()  # the background is clipped to the disc


def test_cli_tileable_clip_and_one_element(tmp_path):
    out = tmp_path / "t.svg"
    assert main(["synthesize", str(_dots(tmp_path)), "-o", str(out), "--scale", "1.5",
                 "--levels", "1", "--iterations", "2", "--quiet", "--tileable", "--clip"]) == 0
    text = out.read_text()
    assert 'clip-path="url(#cvt-clip)"' in text
    one = _file(tmp_path, "one.svg", '<rect width="100" height="100" fill="#eee"/>'
                '<circle cx="50" cy="50" r="5"/>')
    assert main(["synthesize", str(one), "-o", str(out), "--scale", "2", "--quiet"]) == 0
    assert len(load_svg(out, "groups").elements) == 4  # the exemplar's density, 4x the area


@pytest.mark.parametrize("body", [
    '<rect width="100" height="100" fill="red"/>',  # only a background
    '<image width="100" height="100" href="x.png"/>',
])
def test_cli_nothing_to_arrange_is_a_one_line_error(tmp_path, capsys, body):
    code = main(["synthesize", str(_file(tmp_path, "b.svg", body)), "-o",
                 str(tmp_path / "o.svg"), "--scale", "2", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and not (tmp_path / "o.svg").exists()


def test_cli_gradient_and_pattern_backgrounds_give_an_output(tmp_path):
    defs = ('<defs><linearGradient id="g"><stop offset="0" stop-color="red"/><stop offset="1" '
            'stop-color="blue"/></linearGradient><pattern id="p" width="10" height="10" '
            'patternUnits="userSpaceOnUse"><circle cx="5" cy="5" r="2"/></pattern></defs>')
    body = (defs + '<rect width="100" height="100" fill="url(#g)"/><rect width="100" '
            'height="100" fill="url(#p)"/><circle cx="30" cy="30" r="5"/>'
            '<circle cx="70" cy="60" r="5"/>')
    out = tmp_path / "o.svg"
    assert main(["synthesize", str(_file(tmp_path, "g.svg", body)), "-o", str(out),
                 "--scale", "2", "--levels", "1", "--iterations", "2", "--quiet"]) == 0
    text = out.read_text()
    assert "url(#g" in text and text.count("url(#p") == 4  # stretched once, tiled 2 x 2
