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


def test_rolled_ratios_are_the_seam_ratio_of_rolled_tiles():
    """Each draw of rolled_ratios is seam_ratio of the tiles rolled by its offsets: the
    estimator's reading where there is no seam (a seamless tile rolled is seamless)."""
    from cvt.seam import line_values, rolled_ratios

    tiles = [_discs(40, 128, seed=s) for s in range(2)]
    rng = np.random.default_rng(5)  # rolled_ratios' draws, reproduced
    offs = [[4 * rng.integers(0, 32, 3) for _ in range(2)] for _ in tiles]  # tile, axis: (3,)
    want = []
    for k in range(3):
        rolled = [np.roll(t, (-int(o[1][k]), -int(o[0][k])), (0, 1)) for t, o in
                  zip(tiles, offs, strict=True)]
        seam, inner = seam_ratio(rolled)
        want.append(seam / inner)
    assert np.allclose(rolled_ratios(tiles, rolls=3, seed=5), want, rtol=1e-4)
    assert len(line_values(tiles[0])[0]) == 128 and len(line_values(tiles[0], 4)[1]) == 32


def test_a_synthetic_seam_lies_above_the_rolled_tiles():
    from cvt.seam import rolled_ratios

    tiles = [_discs(60, 192, seed=s)[:150, :150] for s in range(3)]  # a cut when tiled
    seam, inner = seam_ratio(tiles)
    null = rolled_ratios(tiles, rolls=100)
    assert seam / inner > np.quantile(null, 0.95)
    seamless = rolled_ratios([_discs(60, 192, seed=s) for s in range(3)], rolls=100)
    assert 0.6 < np.median(seamless) < 1.2


def test_ratios_at_the_tiles_own_seam_is_the_seam_ratio():
    """The null and the estimate read the same lines: at offset 0 ratios_at is seam_ratio
    (irregular tiles, sides a multiple of the line grid)."""
    from cvt.seam import ratios_at, tile_lines

    tiles = [_discs(40, 128, seed=s) for s in range(2)]
    seam, inner = seam_ratio(tiles)
    got = ratios_at(tile_lines(tiles), np.zeros((1, 2, 2), int))
    assert np.allclose(got, [seam / inner], rtol=1e-4)


def test_seam_test_scales_the_null_by_the_margin():
    from cvt.seam import seam_test

    null = np.array([1.0, 1.0, 1.5, 2.0])
    assert seam_test(2.0, null) == 0.25  # 1.1 x null = 1.1, 1.1, 1.65, 2.2: one reaches 2
    assert seam_test(2.0, null, margin=1.0) == 0.25
    assert seam_test(1.2, null) == 0.5
    assert seam_test(1.05, null, margin=1.0) == 0.5
    assert seam_test(1.05, null) == 1.0  # ... 1.1 x 1.0 >= 1.05: a seam within 10 % passes


def test_detectable_is_the_factor_flagged_nine_times_in_ten():
    from cvt.seam import LEVEL, detectable, seam_test

    rng = np.random.default_rng(0)
    null = rng.lognormal(0, 0.2, 2000)
    f = detectable(null)
    assert 1.1 < f < 2.5
    draws = rng.lognormal(0, 0.2, 2000)
    flagged = np.mean([seam_test(f * x, null) < 1 - LEVEL for x in draws])
    assert 0.85 < flagged < 0.95
    flagged_less = np.mean([seam_test(0.8 * f * x, null) < 1 - LEVEL for x in draws])
    assert flagged_less < 0.8


def test_the_seam_test_flags_a_cut_and_leaves_seamless_tiles_alone():
    """Paired with its own null: seamless disc tiles are not shown worse than 1.1 x the
    interior, in their own draws nearly never; tiles cut through discs are."""
    from cvt.seam import LEVEL, rolled_ratios, seam_test

    seamless = [_discs(60, 192, seed=s) for s in range(4)]
    null = rolled_ratios(seamless, rolls=200)
    seam, inner = seam_ratio(seamless)
    assert seam_test(seam / inner, null) >= 1 - LEVEL
    other = rolled_ratios(seamless, rolls=200, seed=1)
    assert np.mean([seam_test(x, null) < 1 - LEVEL for x in other]) < 0.06
    cut = [t[:148, :148] for t in seamless]
    seam, inner = seam_ratio(cut)
    assert seam_test(seam / inner, rolled_ratios(cut, rolls=200)) < 1 - LEVEL


def test_colour_step_reads_one_on_a_seamless_tile_and_flags_a_misaligned_one():
    from cvt.seam import misaligned, pooled_ratios, rolled_draws, step_profile, step_ratio

    tiles = [step_profile(_discs(60, 192, seed=s)) for s in range(4)]  # seamless
    seam = pooled_ratios(step_ratio, tiles, np.zeros((1, 4, 2), int))[0]
    null = pooled_ratios(step_ratio, tiles, rolled_draws(tiles, rolls=200))
    assert abs(seam - 1) < 0.3 and abs(np.median(null) - 1) < 0.1
    cut = [step_profile(misaligned(_discs(60, 192, seed=s), 3)) for s in range(4)]
    assert pooled_ratios(step_ratio, cut, np.zeros((1, 4, 2), int))[0] > 1.5


def test_colour_step_in_phase_compares_a_lattice_seam_with_the_interior_cell_borders():
    """A lattice tile whose cells have a dark border (grout): the wrap runs along a cell
    border, so against the lines beside it it reads like a seam, against the interior cell
    borders (the image's periods) exactly 1; cut out of register, or cut mid-cell, it has no
    period left and reads as the seam it is."""
    from cvt.seam import (
        NEAR,
        misaligned,
        phase_step_ratio,
        pooled_ratios,
        rolled_draws,
        step_lines,
        step_profile,
        step_ratio,
    )

    cell = _discs(4, 48, seed=2)
    cell[:2], cell[:, :2] = 0.1, 0.1  # grout along the cell border
    lattice = np.tile(cell, (4, 4, 1))  # (192, 192, 3)
    lines = step_lines(lattice)
    assert [sorted(x.offsets.tolist()) for x in lines] == [[48, 96, 144]] * 2
    at0 = np.zeros((1, 1, 2), int)
    assert pooled_ratios(step_ratio, [step_profile(lattice)], at0)[0] > 3  # vs its neighbours
    assert pooled_ratios(phase_step_ratio, [lines], at0)[0] == 1.0
    rolled = pooled_ratios(phase_step_ratio, [lines], rolled_draws([lines], rolls=50))
    # every line equals its translates: 1, or 0 on a flat line (no step, read at the floor)
    assert rolled.max() == 1.0 and set(np.unique(rolled).tolist()) <= {0.0, 0.5, 1.0}
    for bad in (misaligned(lattice, 4), lattice[:170, :170]):
        lines = step_lines(bad)
        assert [len(x.offsets) for x in lines] == [2 * NEAR] * 2  # no period: the neighbours
        assert pooled_ratios(phase_step_ratio, [lines], at0)[0] > 1.5
    seamless = _discs(60, 192, seed=0)  # no period: the same as the plain colour step
    assert np.allclose(pooled_ratios(phase_step_ratio, [step_lines(seamless)], at0),
                       pooled_ratios(step_ratio, [step_profile(seamless)], at0))


def test_step_profile_is_the_step_between_neighbouring_columns_and_rows_wrapping():
    from cvt.seam import step_profile, step_ratio

    img = np.zeros((4, 6, 3), np.float32)
    img[:, 3:] = 1.0  # a white right half: steps across columns 2 | 3 and 5 | 0 (the seam)
    cols, rows = step_profile(img)
    assert cols.tolist() == [3, 0, 0, 3, 0, 0] and rows.tolist() == [0, 0, 0, 0]
    assert np.isclose(step_ratio(cols, np.array([0]), near=1)[0], 3 / 1e-3)  # flat: floor


def test_pooled_ratios_weigh_every_tile_axis_alike():
    from cvt.seam import pooled_ratios

    tiles = [(np.array([2.0, 1.0]), np.array([1.0, 1.0])), (np.array([9.0, 9.0]),) * 2]
    first = lambda v, at: v[at] / v.mean()  # noqa: E731
    got = pooled_ratios(first, tiles, np.array([[[0, 0], [0, 0]], [[1, 1], [1, 1]]]))
    assert np.allclose(got, [(4 / 3 + 1 + 1 + 1) / 4, (2 / 3 + 1 + 1 + 1) / 4])
