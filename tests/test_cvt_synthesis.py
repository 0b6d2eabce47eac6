"""End to end: the output holds only exact translated copies of input elements."""

import re
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cvt.svg import SVG_NS, load_svg, parse_svg
from cvt.synthesis import SynthesisConfig, result_svg, synthesize

EXEMPLARS = Path(__file__).resolve().parents[1] / "cvt" / "exemplars"
CFG = SynthesisConfig(levels=2, iterations=3, seed=5)


@pytest.fixture(scope="module")
def run():
    ex = load_svg(EXEMPLARS / "stars_and_dots.svg")
    states = []
    res = synthesize(ex, (300.0, 260.0), CFG, on_iteration=states.append)
    return ex, res, result_svg(ex, res), states


def _strip_ids(node):
    for n in node.iter():
        if n.get("id"):
            n.set("id", re.sub(r"-c\d+$", "", n.get("id")))
    return ET.tostring(node)


def test_output_is_only_translated_copies_of_input_elements(run):
    ex, res, text, _ = run
    root = ET.fromstring(text)
    assert root.get("viewBox") == "0 0 300 260"
    groups = [c for c in root if c.tag == f"{{{SVG_NS}}}g"]
    assert len(groups) == len(res.placements) > 10
    originals = {ET.tostring(e.node) for e in ex.elements}
    out = parse_svg(text.encode())
    assert len(out.elements) == len(groups)
    for g, oe in zip(groups, out.elements, strict=True):
        dx, dy = map(float, re.fullmatch(r"translate\(([^,]+),([^)]+)\)", g.get("transform"))
                     .groups())
        (child,) = list(g)
        assert _strip_ids(child) in originals  # the markup is a verbatim copy
        src = next(e for e in ex.elements if ET.tostring(e.node) == _strip_ids(child))
        for a, b in zip([r for s in src.shapes for r in s.rings],
                        [r for s in oe.shapes for r in s.rings], strict=True):
            np.testing.assert_allclose(a + [dx, dy], b, atol=1e-4)


def test_elements_cover_the_output(run):
    ex, res, _, _ = run
    centers = np.array([[p.dx, p.dy] for p in res.placements]) + np.array(
        [(ex.elements[p.element].bbox[:2] + ex.elements[p.element].bbox[2:]) / 2
         for p in res.placements])
    for qx in (0, 1, 2):  # every third of the output holds elements
        xs = centers[:, 0]
        assert ((xs >= qx * 100) & (xs < (qx + 1) * 100)).sum() >= 3
    expected = len(ex.elements) * (300 * 260) / (200 * 200)  # same density as the input
    assert 0.6 * expected <= len(res.placements) <= 1.6 * expected


def test_matches_of_every_iteration_are_kept_for_the_next_step(run):
    _, res, _, states = run
    assert len(states) == CFG.levels * CFG.iterations
    for st in states:
        assert st.matches.center.shape[0] == st.matches.matched.shape[0]
        assert st.matches.out_nbr.shape == st.matches.matched.shape
    assert [e[:2] for e in res.energies] == [(s.level, s.iteration) for s in states]
    assert len(res.samples_per_level) == CFG.levels


def test_same_seed_same_output(run):
    ex, _, text, _ = run
    again = result_svg(ex, synthesize(ex, (300.0, 260.0), CFG))
    assert again == text


def test_random_init_starts_elsewhere_and_still_fills_the_output():
    ex = load_svg(EXEMPLARS / "rings.svg")
    cfg = SynthesisConfig(levels=1, iterations=2, init="random")
    res = synthesize(ex, (220.0, 220.0), cfg)
    patch = synthesize(ex, (220.0, 220.0), replace(cfg, init="patch"))
    where = lambda r: {(p.element, round(p.dx), round(p.dy)) for p in r.placements}  # noqa: E731
    assert where(res) != where(patch)  # the init option is honoured
    assert len(res.placements) > 5
    xs = [p.dx + (ex.elements[p.element].bbox[0] + ex.elements[p.element].bbox[2]) / 2
          for p in res.placements]
    assert min(xs) < 110 < max(xs)  # elements in both halves of the output


def test_tiny_exemplar_without_namespace():
    svg = (b'<svg viewBox="0 0 100 100"><circle cx="20" cy="20" r="5" fill="red"/>'
           b'<rect x="50" y="50" width="10" height="6"/><circle cx="70" cy="20" r="5"/></svg>')
    ex = parse_svg(svg)
    res = synthesize(ex, (150.0, 150.0), SynthesisConfig(iterations=2))
    assert len(res.placements) >= 3
    assert len(parse_svg(result_svg(ex, res).encode()).elements) == len(res.placements)


def test_backtracking_keeps_the_energy_from_rising_within_a_level():
    ex = load_svg(EXEMPLARS / "flowers.svg")
    states = []
    # clustering off: it changes features, hence eq. 4 itself, between the steps
    synthesize(ex, (300.0, 300.0), SynthesisConfig(levels=1, iterations=4, backtrack=True,
                                                    add_samples=False, clustering="none"),
               states.append)
    e = [s.energy for s in states]
    assert all(b <= a + 1e-6 for a, b in zip(e, e[1:], strict=False))
