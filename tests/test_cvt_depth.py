"""Pair votes of matched neighborhoods (seed 000 Figs. 4 and 6) and Order-By-Preferences."""

import numpy as np
import pytest
import torch

from cvt.depth import cluster_preferences, order_by_preferences, sample_order
from cvt.pair_votes import pair_votes
from cvt.search import Matches

# Three matched neighborhood pairs (a), (b), (c) over the same output samples 0..3, centered
# at samples 0, 1, 2 (Figs. 4 and 6); sample 3's own neighborhood holds nothing else.
# Input sample k has cluster == z == IN_CLUSTER[k].
IN_CLUSTER = torch.tensor([0, 1, 1, 0,  # (a): m(0), m(3) share a cluster; z m(0) < z m(1)
                           2, 3, 3, 4,  # (b): different clusters;        z m(0) < z m(1)
                           6, 5, 5, 7])  # (c): different clusters;       z m(0) > z m(1)
TOY = Matches(
    center=torch.tensor([0, 5, 10, 3]),
    out_nbr=torch.tensor([[1, 2, 3], [0, 2, 3], [0, 1, 3], [-1, -1, -1]]),
    matched=torch.tensor([[1, 2, 3], [4, 6, 7], [8, 9, 11], [-1, -1, -1]]),
    cost=torch.zeros(4),
)
POS = torch.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])  # all within 2 delta
DELTA = 1.0


def _votes():
    return pair_votes(TOY, POS, IN_CLUSTER, IN_CLUSTER, 4 * DELTA)


def _value(a, b, x, y, values):
    hit = ((a == x) & (b == y)).nonzero().flatten()
    assert len(hit) == 1
    return float(values[hit[0]])


def test_every_pair_is_voted_on_by_the_three_neighborhoods():
    v = _votes()
    assert len(v.a) == 6 and (v.a < v.b).all()
    assert (v.n == 3).all()  # |N_n| = 3 for every pair, as in the figures


def test_link_confidence_of_figure_6():
    v = _votes()
    link = v.link
    assert _value(v.a, v.b, 0, 3, link) == pytest.approx(1 / 3)  # same cluster in (a) only
    assert _value(v.a, v.b, 1, 2, link) == pytest.approx(1.0)  # same cluster in all three
    assert _value(v.a, v.b, 0, 1, link) == pytest.approx(0.0)


def test_pairwise_order_of_figure_4():
    a, b, f_ab, f_ba = sample_order(_votes(), POS, DELTA)
    assert _value(a, b, 0, 1, f_ab) == pytest.approx(2 / 3)  # below in (a), (b), not (c)
    assert _value(a, b, 0, 1, f_ba) == pytest.approx(1 / 3)
    assert _value(a, b, 1, 2, f_ab) == 0.0 and _value(a, b, 1, 2, f_ba) == 0.0  # same input z


def test_pairs_beyond_two_delta_have_no_order():
    far = POS * torch.tensor([[3.0, 1.0]])  # 0-1 and 2-3 now 3 delta apart
    a, b, _, _ = sample_order(pair_votes(TOY, far, IN_CLUSTER, IN_CLUSTER, 4.0), far, DELTA)
    pairs = set(zip(a.tolist(), b.tolist(), strict=True))
    assert (0, 1) not in pairs and (0, 2) in pairs


def test_cluster_preferences_average_the_sample_pairs():
    cluster = torch.tensor([0, 1, 1, 0])
    pref = cluster_preferences(_votes(), POS, cluster, 2, DELTA)
    # f_s(0,1) = 2/3, f_s(0,2) = 2/3, f_s(3,1) = f_s(3,2) = 1/3: eq. 8 averages them
    assert pref[0, 1] == pytest.approx((2 / 3 + 2 / 3 + 1 / 3 + 1 / 3) / 4)
    assert pref[0, 0] == 0.0


@pytest.mark.parametrize("seed", range(5))
def test_order_by_preferences_is_consistent_on_acyclic_preferences(seed):
    rng = np.random.default_rng(seed)
    n = 15
    hidden = rng.permutation(n)  # hidden[k] = rank of item k
    pref = np.zeros((n, n))
    for u in range(n):
        for v in range(n):
            if hidden[u] < hidden[v] and rng.random() < 0.3:
                pref[u, v] = rng.uniform(0.6, 1.0)  # "u below v", with some doubt
                pref[v, u] = 1 - pref[u, v]
    # a hub with many incoming and one outgoing edge fools the plain greedy, not the SCC step
    order = order_by_preferences(pref, key=rng.permutation(n))
    assert sorted(order.tolist()) == list(range(n))
    rank = np.argsort(order)
    u, v = np.nonzero(pref > pref.T)
    assert (rank[u] < rank[v]).all()


def test_order_by_preferences_breaks_ties_by_key_and_resolves_cycles():
    assert order_by_preferences(np.zeros((3, 3)), key=np.array([2, 0, 1])).tolist() == [1, 2, 0]
    cyc = np.zeros((3, 3))
    cyc[0, 1], cyc[1, 2], cyc[2, 0] = 0.9, 0.6, 0.7  # 0<1<2<0: 0<1 is the strongest
    order = order_by_preferences(cyc).tolist()
    assert sorted(order) == [0, 1, 2] and order.index(0) < order.index(1)
