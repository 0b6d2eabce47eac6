"""Clustering step (seed 000 sec. 6.5): operators are applied exactly when they lower eq. 9."""

import numpy as np
import pytest
import torch

from cvt.clustering import Clustering, ClusteringParams, changed_samples, cluster_step
from cvt.pair_votes import PairVotes
from cvt.shape_energy import ShapeEnergy
from cvt.spectral import normalized_cut, spectral_clusters

DELTA = 1.0
GRID = torch.tensor([[x, y] for y in range(3) for x in range(3)], dtype=torch.float64)  # (9, 2)


def _scene(offsets):
    """Input: two 3x3 elements (clusters 0, 1) far apart. Output: copies of the elements
    listed in ``offsets`` = [(input cluster, (dx, dy))], matched sample by sample (mu_s)."""
    in_pos = torch.cat([GRID, GRID + torch.tensor([20.0, 0.0])])  # (18, 2)
    in_cluster = torch.tensor([0] * 9 + [1] * 9)
    pos, mu = [], []
    for c, (dx, dy) in offsets:
        pos.append(in_pos[9 * c : 9 * c + 9] + torch.tensor([dx, dy]))
        mu.append(torch.arange(9 * c, 9 * c + 9))
    return torch.cat(pos), torch.cat(mu), in_pos, in_cluster


def _votes(pos, linked, lam=4.0):
    """Votes: every pair within lam delta is seen by 2 neighborhoods; both say "same cluster"
    when ``linked(a, b)``."""
    a, b = torch.triu_indices(len(pos), len(pos), 1)
    near = (pos[a] - pos[b]).norm(dim=1) < lam * DELTA
    a, b = a[near], b[near]
    same = torch.tensor([2 * int(linked(i, j)) for i, j in zip(a.tolist(), b.tolist(),
                                                                 strict=True)])
    zero = torch.zeros_like(a)
    return PairVotes(a, b, torch.full_like(a, 2), same, zero, zero)


def _run(pos, mu, in_pos, in_cluster, labels, linked, **ops):
    shape = ShapeEnergy(pos, mu, in_pos, in_cluster, DELTA)
    params = ClusteringParams(**ops)
    return cluster_step(pos, torch.tensor(labels), _votes(pos, linked), shape, DELTA, params)


def _element(k):
    return k // 9  # output sample k belongs to the (k // 9)-th copied element


def _same_partition(a, b):
    return len(set(zip(a.tolist(), b.tolist(), strict=True))) == len(set(a.tolist())) == len(
        set(b.tolist()))


def test_switch_that_lowers_the_link_energy_is_applied():
    pos, mu, in_pos, in_cl = _scene([(0, (0, 0)), (1, (3, 0))])  # two elements side by side
    labels = [0] * 9 + [1] * 9
    labels[2] = 1  # sample 2 (right edge of element 0) wrongly in cluster 1
    new, stats = _run(pos, mu, in_pos, in_cl, labels, lambda a, b: _element(a) == _element(b),
                      merge=False, split=False)
    assert stats.switches >= 1
    assert new[2] == new[0] != new[9]
    assert _same_partition(new, torch.tensor([0] * 9 + [1] * 9))
    assert stats.energy[1] < stats.energy[0]


def test_switch_that_raises_the_link_energy_is_not_applied():
    pos, mu, in_pos, in_cl = _scene([(0, (0, 0)), (1, (3, 0))])
    labels = torch.tensor([0] * 9 + [1] * 9)
    new, stats = _run(pos, mu, in_pos, in_cl, labels.tolist(),
                      lambda a, b: _element(a) == _element(b), merge=False, split=False)
    assert stats.switches == 0 and _same_partition(new, labels)


def test_merge_of_two_halves_of_one_element_is_applied():
    pos, mu, in_pos, in_cl = _scene([(0, (0, 0)), (1, (8, 0))])
    labels = [0] * 6 + [1] * 3 + [2] * 9  # element 0 broken into two clusters
    new, stats = _run(pos, mu, in_pos, in_cl, labels, lambda a, b: _element(a) == _element(b),
                      switch=False)
    assert stats.merges == 1 and stats.splits == 0
    assert _same_partition(new, torch.tensor([0] * 9 + [1] * 9))
    assert stats.energy[2] < stats.energy[1]


def test_merge_of_two_whole_neighboring_elements_is_not_applied():
    pos, mu, in_pos, in_cl = _scene([(0, (0, 0)), (1, (3.5, 0))])  # 1.5 delta apart
    labels = torch.tensor([0] * 9 + [1] * 9)
    new, stats = _run(pos, mu, in_pos, in_cl, labels.tolist(),
                      lambda a, b: _element(a) == _element(b), switch=False)
    assert stats.merges == 0 and stats.splits == 0 and _same_partition(new, labels)


def test_split_of_two_glued_elements_is_applied():
    pos, mu, in_pos, in_cl = _scene([(0, (0, 0)), (1, (3, 0))])
    new, stats = _run(pos, mu, in_pos, in_cl, [0] * 18,
                      lambda a, b: _element(a) == _element(b), switch=False)
    assert stats.splits == 1
    assert _same_partition(new, torch.tensor([0] * 9 + [1] * 9))
    assert stats.energy[2] < stats.energy[1]


def test_split_of_a_whole_element_is_not_applied():
    pos, mu, in_pos, in_cl = _scene([(0, (0, 0)), (1, (8, 0))])
    labels = torch.tensor([0] * 9 + [1] * 9)
    new, stats = _run(pos, mu, in_pos, in_cl, labels.tolist(), lambda a, b: True, switch=False)
    assert stats.splits == 0 and _same_partition(new, labels)


def test_energy_matches_its_definition():
    pos, mu, in_pos, in_cl = _scene([(0, (0, 0)), (1, (3, 0))])
    linked = lambda a, b: _element(a) == _element(b)  # noqa: E731
    labels = torch.tensor([0] * 9 + [1] * 9)
    state = Clustering(pos, labels, _votes(pos, linked), ShapeEnergy(pos, mu, in_pos, in_cl,
                                                                     DELTA), DELTA,
                       ClusteringParams())
    # eq. 12-13 over ordered pairs: l = 1 inside (-1 each), l = 0 across clusters (-1 each)
    n_pairs = len(_votes(pos, linked).a)
    assert state.link_energy() == pytest.approx(-2 * n_pairs)
    assert state.shape_energy() == pytest.approx(0.0, abs=1e-9)  # exact copies
    assert state.energy() == pytest.approx(-2 * n_pairs)


def test_normalized_cut_separates_two_cliques():
    w = np.zeros((7, 7))
    w[:3, :3] = 1.0
    w[3:, 3:] = 1.0
    w[2, 3] = w[3, 2] = 0.05
    np.fill_diagonal(w, 0)
    side = normalized_cut(w)
    assert side[:3].all() != side[3:].any() and len(set(side[:3])) == 1


def test_spectral_clusters_find_the_components_and_share_k():
    a = np.array([0, 1, 0, 3, 4, 3, 6])
    b = np.array([1, 2, 2, 4, 5, 5, 7])
    labels = spectral_clusters(a, b, np.ones(len(a)), 8, k=3)
    assert len(set(labels[:3])) == 1 and len(set(labels[3:6])) == 1
    assert len(set(labels.tolist())) == 3


def test_changed_samples_marks_clusters_whose_member_set_changed():
    old = torch.tensor([5, 5, 7, 7, 9])
    new = torch.tensor([0, 0, 1, 2, 2])  # 5 kept (renamed), 7 split, 9 joined by one of 7
    assert changed_samples(old, new).tolist() == [False, False, True, True, True]
