"""The seam estimator (cvt/seam.py): patch SWD across the seam lines vs interior lines."""

import numpy as np

from cvt.seam import MARGIN, controls, periods, seam_ratio


def _discs(n: int, size: int, seed: int, wrap: bool = True) -> np.ndarray:
    """Random coloured discs on a light ground, drawn on a torus (``wrap``: every disc also
    at its periodic images, so the image tiles seamlessly). Shape: (size, size, 3)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size].astype(np.float32)
    img = np.full((size, size, 3), 0.95, np.float32)
    for _ in range(n):
        cx, cy, r = *rng.uniform(0, size, 2), rng.uniform(5, 12)
        colour = rng.uniform(0, 0.8, 3)
        shifts = [(i * size, j * size) for i in (-1, 0, 1) for j in (-1, 0, 1)] if wrap \
            else [(0, 0)]
        for sx, sy in shifts:
            img[(x - cx - sx) ** 2 + (y - cy - sy) ** 2 <= r * r] = colour
    return img


def test_an_exactly_periodic_image_reads_one():
    cell = _discs(6, 48, seed=0, wrap=True)
    img = np.tile(cell, (4, 4, 1))  # (192, 192, 3), period 48 px
    assert 48 in periods(img, 1).tolist() and 48 in periods(img, 0).tolist()
    assert set(controls(img, 1).tolist()) == {48, 96, 144}  # the seam's translates only
    seam, inner = seam_ratio([img])
    assert abs(seam / inner - 1) < 0.02


def test_controls_follow_each_axis_own_period():
    cell = _discs(5, 48, seed=2, wrap=True)[:32]  # (32, 48, 3): not a torus across y
    img = np.tile(np.tile(cell, (1, 1, 1)), (4, 4, 1))  # (128, 192, 3)
    assert set(controls(img, 1).tolist()) == {48, 96, 144}  # vertical lines: columns
    assert set(controls(img, 0).tolist()) == {32, 64, 96}  # horizontal lines: rows
    seam, inner = seam_ratio([img])
    assert abs(seam / inner - 1) < 0.02


def test_an_irregular_image_has_no_period_and_is_compared_with_many_lines():
    img = _discs(60, 192, seed=1)
    assert not any(min(t, 192 - t) >= MARGIN for t in periods(img, 1))
    assert len(controls(img, 1)) > 10


def test_a_synthetic_seam_reads_well_above_a_seamless_tile():
    tiles = [_discs(60, 192, seed=s) for s in range(3)]  # seamless by construction
    seam, inner = seam_ratio(tiles)
    cut = [t[:150, :150] for t in tiles]  # cut through discs and gaps: a seam when tiled
    seam_cut, inner_cut = seam_ratio(cut)
    assert seam / inner < 1.25
    assert seam_cut / inner_cut > 1.5 * seam / inner and seam_cut / inner_cut > 1.5
