"""A picture's lattice (neuraltex.raster_lattice): tiles found to the pixel, everything else
refused."""

import numpy as np
import pytest

from neuraltex.raster_lattice import _reduced, raster_lattice, self_correlation


def _tile(h: int, w: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).random((h, w, 3))


def _same_lattice(found: np.ndarray, expected: np.ndarray) -> bool:
    """Both bases span one lattice: each is an integer combination of the other."""
    k = np.linalg.solve(expected.T, found.T)
    return bool(np.allclose(k, np.round(k), atol=0.02)
                and np.isclose(abs(np.linalg.det(found)), abs(np.linalg.det(expected)), rtol=0.02))


def test_a_repeated_tile_is_found_to_the_pixel():
    pic = np.tile(_tile(20, 24), (5, 4, 1))  # 100 x 96
    basis = raster_lattice(pic)
    assert basis is not None
    assert _same_lattice(basis, np.array([[24.0, 0], [0, 20]]))
    assert np.abs(basis - np.round(basis)).max() < 0.05


def test_a_resampled_tile_has_its_period_to_a_tenth_of_a_pixel():
    """A smooth 20 px tile repeated 8 times and resampled by 203 / 160: period 25.375 px, no
    whole shift repeats exactly, the parabola refines the peak."""
    from PIL import Image
    from scipy.ndimage import gaussian_filter

    tile = gaussian_filter(_tile(20, 20), (1.5, 1.5, 0), mode="wrap")
    pic = Image.fromarray((np.tile(tile, (8, 8, 1)) * 255).astype(np.uint8))
    basis = raster_lattice(np.asarray(pic.resize((203, 203), Image.BILINEAR)) / 255)
    assert basis is not None
    assert np.allclose(np.sort(np.abs(basis).max(1)), 20 * 203 / 160, atol=0.1)
    assert np.abs(basis).min() < 0.1  # along the axes


def test_a_staggered_tile_gives_the_reduced_basis():
    """Rows of a 32 px tile, each row shifted by 16 px (a brick bond): the lattice is
    (32, 0), (16, 24), not the axis-aligned (32, 0), (0, 48)."""
    tile = _tile(24, 32)
    rows = [np.roll(np.tile(tile, (1, 4, 1)), 16 * (r % 2), axis=1) for r in range(5)]
    basis = raster_lattice(np.concatenate(rows)[:, :128])
    assert basis is not None
    assert _same_lattice(basis, np.array([[32.0, 0], [16, 24]]))
    assert np.isclose(abs(np.linalg.det(basis)), 32 * 24, rtol=0.01)
    assert min(np.linalg.norm(basis, axis=1)) == pytest.approx(np.hypot(16, 24), abs=0.5)


def test_the_grid_of_a_noisy_tile_is_kept_up_to_a_tenth_of_its_contrast():
    pic = np.tile(_tile(16, 16), (6, 6, 1))
    noisy = pic + np.random.default_rng(1).normal(0, 0.03, pic.shape)
    assert _same_lattice(raster_lattice(noisy), np.array([[16.0, 0], [0, 16]]))


@pytest.mark.parametrize("make", [
    lambda: _tile(96, 96),                                           # noise
    lambda: np.ones((64, 64, 3)) * 0.4,                              # flat
    lambda: np.broadcast_to(np.linspace(0, 1, 96)[None, :, None], (96, 96, 3)).copy(),  # ramp
    lambda: np.tile(_tile(1, 24), (96, 4, 1)) + _tile(96, 1, 1),      # stripes: one period
    lambda: np.pad(_tile(60, 60), ((0, 4), (0, 4), (0, 0))),          # one copy only
])
def test_pictures_that_do_not_repeat_a_tile_have_none(make):
    assert raster_lattice(make()) is None


def test_a_tile_shorter_than_the_shortest_period_gives_a_lattice_of_its_multiples():
    """A 4 px checker: cells of 8 px (whole multiples of the tile) continue it exactly."""
    basis = raster_lattice(np.tile(_tile(4, 4), (16, 16, 1)))
    assert basis is not None and min(np.linalg.norm(basis, axis=1)) >= 8
    k = np.linalg.solve(np.diag([4.0, 4.0]), basis.T)
    assert np.allclose(k, np.round(k), atol=0.02)  # a sublattice of the tile's


def test_the_correlation_is_one_at_zero_and_at_the_period_of_any_overlap():
    pic = np.tile(_tile(10, 12), (3, 3, 1))  # 30 x 36
    ncc = self_correlation(pic)
    assert ncc.shape == (60, 72)
    assert ncc[0, 0] == pytest.approx(1.0)
    assert ncc[10, 0] == pytest.approx(1.0) and ncc[0, 12] == pytest.approx(1.0)
    assert ncc[20, 24] == pytest.approx(1.0)  # an overlap of a third by a third
    assert ncc[-10 % 60, -24 % 72] == pytest.approx(1.0)  # negative shifts wrap the index
    assert abs(ncc[5, 6]) < 0.3


def test_reduction_keeps_the_lattice_and_makes_it_short():
    basis = _reduced(np.array([[32.0, 0], [80, 24]]))
    assert _same_lattice(basis, np.array([[32.0, 0], [16, 24]]))
    assert np.linalg.norm(basis[1]) <= np.linalg.norm(basis[1] - basis[0])
    assert np.linalg.norm(basis[1]) <= np.linalg.norm(basis[1] + basis[0])


def test_repeats_exactly_only_under_whole_periods_of_an_exact_tile():
    from neuraltex.raster_lattice import repeats_exactly

    pic = np.tile(_tile(20, 24), (4, 4, 1))
    basis = raster_lattice(pic)
    assert repeats_exactly(pic, basis)
    assert repeats_exactly(pic, np.array([[24.0, 20.0], [-24.0, 20.0]]))  # a sublattice too
    assert not repeats_exactly(pic, np.array([[24.0, 0.0], [0.0, 21.0]]))
    assert not repeats_exactly(pic, np.array([[24.5, 0.0], [0.0, 20.0]]))  # not whole pixels
    noisy = pic + np.random.default_rng(1).normal(0, 0.01, pic.shape)
    assert raster_lattice(noisy) is not None and not repeats_exactly(noisy, basis)
