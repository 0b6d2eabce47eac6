"""cvt.free_spot: the screened emptiest spot is the one full scoring picks, bit for bit."""

import numpy as np
import pytest

from cvt.free_spot import emptiest_spot, spot_keys
from cvt.torus import Torus, images


def _reference(spots, half, mb):
    """The full scoring of all spots against all boxes at once (cvt.canvas before the screen)."""
    gap = np.maximum(np.abs(spots[:, None] - (mb[None, :, :2] + mb[None, :, 2:]) / 2)
                     - half - (mb[None, :, 2:] - mb[None, :, :2]) / 2, 0)  # (S, P, 2)
    clear = np.linalg.norm(gap, axis=2).min(1)
    over = np.clip(np.minimum(spots[:, None] + half, mb[None, :, 2:])
                   - np.maximum(spots[:, None] - half, mb[None, :, :2]), 0, None).prod(-1)
    return int(np.lexsort((-clear, over.sum(1)))[0]), over.sum(1), clear


def _boxes(rng, n, size):
    lo = rng.uniform(0, 2, (n, 2))
    return np.c_[lo, lo + rng.uniform(0.01, size, (n, 2))]


@pytest.mark.parametrize("n,size", [(1, 0.1), (5, 0.05), (40, 0.1), (300, 0.3), (700, 0.25)])
def test_emptiest_spot_matches_full_scoring(n, size):
    for seed in range(6):
        rng = np.random.default_rng(seed)
        mb = _boxes(rng, n, size)
        if seed % 2:
            mb = images(mb, Torus.of((0, 0, 2, 2)))
        spots = rng.uniform(0, 2, (600, 2))
        half = rng.uniform(0.005, 0.1, 2)
        best, over, clear = _reference(spots, half, mb)
        assert emptiest_spot(spots, half, mb) == best
        o2, c2 = spot_keys(spots, half, mb)
        assert np.array_equal(o2, over) and np.array_equal(c2, clear)  # same floats


def test_emptiest_spot_ties_go_to_the_first_spot():
    mb = np.array([[0.0, 0.0, 1.0, 1.0]])
    spots = np.array([[0.5, 0.5], [3.0, 0.5], [0.5, 3.0], [3.0, 0.5]])  # 1 and 3 tie, 2 too
    assert emptiest_spot(spots, np.array([0.1, 0.1]), mb) == 1
    covered = np.array([[0.5, 0.5], [0.95, 0.5], [0.5, 0.95], [0.95, 0.5]])  # all overlap
    assert emptiest_spot(covered, np.array([0.1, 0.1]), mb) == 1
