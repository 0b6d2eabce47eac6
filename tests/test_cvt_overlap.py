"""End to end on an overlapping exemplar (stars on discs): whole elements, one per cluster,
exact translated copies, and the exemplar's layering (stars above discs) by depth order."""

import dataclasses
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from cvt.boxes import box_iou
from cvt.svg import SVG_NS, load_svg
from cvt.synthesis import SynthesisConfig, depth_order, result_svg, synthesize

EXEMPLAR = Path(__file__).resolve().parents[1] / "cvt" / "exemplars" / "layered_discs.svg"
CFG = SynthesisConfig(levels=2, iterations=3, seed=3)


@pytest.fixture(scope="module")
def run():
    ex = load_svg(EXEMPLAR)
    res = synthesize(ex, (260.0, 260.0), CFG)
    return ex, res


def _kind(ex, p):
    return ex.elements[p.element].node.tag.rsplit("}", 1)[-1]  # circle (disc) or polygon


def _layering(ex, placements):
    """(agree, disagree): overlapping disc/star pairs drawn with the star above the disc."""
    boxes = np.stack([e.bbox for e in ex.elements])
    moved = np.array([boxes[p.element] + [p.dx, p.dy, p.dx, p.dy] for p in placements])
    iou = box_iou(moved, moved)
    agree = disagree = 0
    for i, j in zip(*np.nonzero(np.triu(iou > 0.02, 1)), strict=True):  # j drawn after i
        ki, kj = _kind(ex, placements[i]), _kind(ex, placements[j])
        if ki != kj:
            agree += kj == "polygon"
            disagree += kj != "polygon"
    return agree, disagree


def test_one_whole_element_per_cluster_and_no_duplicates(run):
    ex, res = run
    clusters = [p.cluster for p in res.placements]
    assert len(clusters) == len(set(clusters)) > 30
    assert all(p.energy <= p.size for p in res.placements)  # sec. 6.6 filtering
    boxes = np.stack([e.bbox for e in ex.elements])
    moved = np.array([boxes[p.element] + [p.dx, p.dy, p.dx, p.dy] for p in res.placements])
    iou = box_iou(moved, moved)
    np.fill_diagonal(iou, 0)
    assert iou.max() < 0.5  # no stacked copies of one element
    kinds = [_kind(ex, p) for p in res.placements]
    assert 0.6 < kinds.count("polygon") / kinds.count("circle") < 1.4  # stars stay with discs


def test_elements_are_exact_translated_input_elements(run):
    ex, res = run
    groups = [g for g in ET.fromstring(result_svg(ex, res)) if g.tag == f"{{{SVG_NS}}}g"]
    assert len(groups) == len(res.placements)
    for g, p in zip(groups, res.placements, strict=True):
        dx, dy = map(float, re.fullmatch(r"translate\(([^,]+),([^)]+)\)",
                                         g.get("transform")).groups())
        assert (dx, dy) == pytest.approx((p.dx, p.dy), abs=1e-3)
        (child,) = list(g)
        assert ET.tostring(child) == ET.tostring(ex.elements[p.element].node)


def test_layering_follows_the_exemplar(run):
    ex, res = run
    agree, disagree = _layering(ex, res.placements)
    assert agree >= 15 and disagree <= 0.1 * agree
    # The order comes from the matched neighborhoods, not from the input z tie-break: with
    # scrambled z the plain z order is about a coin flip, depth order still gets it right.
    rng = np.random.default_rng(0)
    scrambled = [dataclasses.replace(p, z=int(rng.integers(10**6))) for p in res.placements]
    a0, d0 = _layering(ex, sorted(scrambled, key=lambda p: p.z))
    assert d0 > 0.25 * (a0 + d0)
    delta = ex.size * CFG.deltas[-1]
    a1, d1 = _layering(ex, depth_order(scrambled, res.outputs[-1], res.matches[-1],
                                       res.inputs[-1], delta))
    assert d1 <= 0.1 * a1
