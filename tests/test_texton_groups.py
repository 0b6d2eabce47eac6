"""Texton groups (neuraltex.texton_groups) and the group elements of cvt.gaussians."""

from dataclasses import replace

import numpy as np
import torch

from cvt.gaussians import gaussian_exemplar
from neuraltex.texton_groups import group_kinds, texton_boxes, texton_groups
from tests.conftest import make_textons


def _two_objects():
    """Two clusters of 4 overlapping small textons (0.3 apart) and one loose speck."""
    t = make_textons(B=1, K=9, seed=1)
    centres = [(0.2, 0.2)] * 4 + [(0.7, 0.6)] * 4 + [(0.2, 0.8)]
    off = [(0, 0), (0.03, 0), (0, 0.03), (0.03, 0.03)] * 2 + [(0, 0)]
    mu = torch.tensor([[c[0] + o[0], c[1] + o[1]] for c, o in zip(centres, off, strict=True)])[None]
    cov = (torch.eye(2) * 0.02 ** 2).expand(1, 9, 2, 2).clone()
    return replace(t, mu=mu, cov=cov, canvas=(1.0, 1.0))


def test_overlapping_textons_join_and_separate_objects_stay_apart():
    t = _two_objects()
    groups = texton_groups(t, torch.arange(9))
    assert groups == [[0, 1, 2, 3], [4, 5, 6, 7], [8]]


def test_groups_stop_at_the_extent():
    t = _two_objects()
    # each object's box: 0.03 + 2 * 2 * 0.02 = 0.11 wide: a cap of 0.05 keeps them apart
    assert len(texton_groups(t, torch.arange(9), extent=0.05)) == 9
    assert len(texton_groups(t, torch.arange(9), extent=0.2)) == 3
    # a reach that spans the 0.5 gap joins everything the cap allows
    assert len(texton_groups(t, torch.arange(9), reach=100.0, extent=2.0)) == 1


def test_group_kinds_follow_size_and_boxes_are_the_m2_ellipse():
    t = _two_objects()
    kinds = group_kinds(t, torch.arange(9), [[0, 1, 2, 3], [4, 5, 6, 7], [8]])
    assert kinds[0] == kinds[1] != kinds[2]  # 4 textons vs 1: 4x the area, one bin apart
    box = texton_boxes(np.array([[0.5, 0.5]]), np.diag([0.01, 0.04])[None])
    assert np.allclose(box, [[0.3, 0.1, 0.7, 0.9]])


def test_a_group_is_one_element_of_several_ellipses():
    mu = np.array([[0.2, 0.2], [0.25, 0.2], [0.7, 0.7]])
    cov = np.repeat(np.eye(2)[None] * 0.01, 3, 0)
    ex = gaussian_exemplar(mu, cov, np.zeros((2, 1)), (1.0, 1.0), groups=[[0, 1], [2]])
    assert len(ex.elements) == 2 and len(ex.elements[0].shapes) == 2
    assert ex.elements[0].markup.count("<ns0:ellipse") + ex.elements[0].markup.count(
        "<ellipse") == 2
    assert np.allclose(ex.elements[0].bbox[[0, 2]], [0.0, 0.45], atol=1e-6)
