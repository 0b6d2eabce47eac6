"""Quantitative metrics: zero against the exemplar itself, and they catch what they claim to."""

from pathlib import Path

import numpy as np
import pytest

from cvt.baselines import method_config, random_placement
from cvt.metrics import Layout, composition, layering, pair_correlation, pcf_distance
from cvt.svg import load_svg
from cvt.synthesis import SynthesisConfig

EXEMPLARS = Path(__file__).resolve().parents[1] / "cvt" / "exemplars"


@pytest.fixture(scope="module")
def discs():
    ex = load_svg(EXEMPLARS / "layered_discs.svg")
    return ex, Layout.of_exemplar(ex)


def test_exemplar_against_itself_scores_perfectly(discs):
    ex, ref = discs
    same = Layout.of_exemplar(ex)
    assert pcf_distance(ref, same) == pytest.approx(0.0)
    assert all(v == pytest.approx(0.0) for v in composition(ref, same).values())
    assert layering(ref, same) == 1.0


def test_reversed_drawing_order_breaks_the_layering(discs):
    ex, ref = discs
    flipped = Layout(ex, ref.placements[::-1], ref.size)
    assert layering(ref, flipped) == 0.0
    assert pcf_distance(ref, flipped) == pytest.approx(0.0)  # same places, other order


def test_stacked_copies_count_as_duplicates_and_overlap(discs):
    ex, ref = discs
    doubled = Layout(ex, ref.placements + [(e, dx + 0.5, dy) for e, dx, dy in ref.placements],
                     ref.size)
    comp = composition(ref, doubled)
    assert comp["duplicates"] > 0.9
    assert comp["density"] == pytest.approx(1.0)
    assert comp["overlap"] > 0.5


def test_pair_correlation_of_uniform_points_is_about_one():
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, 100, (600, 2))
    g = pair_correlation(pts, pts, (100, 100), np.linspace(4, 20, 9), 2.0, same=True)
    assert 0.85 < g.mean() < 1.15


def test_random_placement_does_not_overlap_and_keeps_the_density():
    ex = load_svg(EXEMPLARS / "stars.svg")
    res = random_placement(ex, (300.0, 300.0), seed=2)
    boxes = np.stack([ex.elements[p.element].bbox + [p.dx, p.dy, p.dx, p.dy]
                      for p in res.placements])
    lo = np.maximum(boxes[:, None, :2], boxes[None, :, :2])
    hi = np.minimum(boxes[:, None, 2:], boxes[None, :, 2:])
    inter = ((hi - lo) > 0).all(-1)
    np.fill_diagonal(inter, False)
    assert not inter.any()
    assert 0.8 * 30 * 2.25 <= len(res.placements) <= 30 * 2.25 + 1


def test_method_configs():
    base = SynthesisConfig()
    assert method_config("full", base) == base
    assert method_config("no-clustering", base).clustering == "none"
    assert method_config("spectral", base).clustering == "spectral"
    assert method_config("no-features", base).w_f == 0
    assert method_config("no-link", base).cluster.w_l == 0
    assert method_config("no-shape", base).cluster.w_s == 0
    with pytest.raises(ValueError):
        method_config("magic", base)
