"""Clustered samples: Poisson-disk spacing, one cluster per element, shape contexts."""

from pathlib import Path

import pytest
import torch

from cvt.sampling import hierarchy, sample_exemplar
from cvt.shape_context import N_FEAT, chi2, shape_contexts
from cvt.svg import load_svg

EXEMPLARS = Path(__file__).resolve().parents[1] / "cvt" / "exemplars"


@pytest.mark.parametrize("name", ["stars", "rings", "swirls", "mixed_four", "layered_discs"])
def test_poisson_disk_min_distance_within_each_element(name):
    ex = load_svg(EXEMPLARS / f"{name}.svg")
    lv = hierarchy(ex.size)[-1]
    s = sample_exemplar(ex, lv.delta)
    assert set(s.cluster.tolist()) == set(range(len(ex.elements)))  # every element sampled
    for c in range(len(ex.elements)):
        p = s.pos[s.cluster == c].double()
        if len(p) > 1:
            d = torch.cdist(p, p) + torch.eye(len(p), dtype=p.dtype) * 1e9
            assert d.min() >= lv.delta * (1 - 1e-6)


def test_samples_lie_on_the_element():
    ex = load_svg(EXEMPLARS / "packed_circles.svg")
    s = sample_exemplar(ex, hierarchy(ex.size)[-1].delta)
    for e in ex.elements:
        box = torch.tensor(e.bbox, dtype=s.pos.dtype)
        p = s.pos[s.cluster == e.index]
        assert ((p >= box[:2] - 1e-4) & (p <= box[2:] + 1e-4)).all()


def test_hierarchy_matches_the_paper():
    lv = hierarchy(120.0)
    assert [round(v.delta, 6) for v in lv] == [6.0, 4.0, 3.0]
    assert [round(v.radius, 6) for v in lv] == [20.0, 15.0, 10.0]
    assert hierarchy(120.0, levels=1)[0].delta == pytest.approx(3.0)


def test_shape_context_is_translation_invariant_and_per_cluster():
    g = torch.Generator().manual_seed(0)
    pos = torch.rand(40, 2, generator=g, dtype=torch.float64) * 50
    cluster = torch.arange(40) % 3
    f = shape_contexts(pos, cluster)
    assert f.shape == (40, N_FEAT)
    torch.testing.assert_close(f, shape_contexts(pos + torch.tensor([123.5, -77.0]), cluster))
    torch.testing.assert_close(f.sum(1), torch.ones(40, dtype=f.dtype))
    # moving another cluster does not change this one's features
    moved = pos.clone()
    moved[cluster == 1] += 5.0
    f2 = shape_contexts(moved, cluster)
    torch.testing.assert_close(f[cluster == 0], f2[cluster == 0])
    assert chi2(f[0], f[0]) == 0


def test_sampling_is_deterministic():
    ex = load_svg(EXEMPLARS / "leaves.svg")
    a, b = sample_exemplar(ex, 8.0, seed=3), sample_exemplar(ex, 8.0, seed=3)
    assert torch.equal(a.pos, b.pos)
