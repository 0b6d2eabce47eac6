"""The seam measures of scripts/synthesis_baselines.py (used by scripts/eval_synthesis.py)."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))

import synthesis_baselines as base  # noqa: E402


def _field(seamless: bool, seed: int = 0) -> np.ndarray:
    """96 x 96 of a periodic random field (low-pass filtered noise): the whole period, which
    is seamless; not seamless: 96 x 96 cut from a period of 128, so the edges that meet
    across the wrap were 32 px apart."""
    n = 96 if seamless else 128
    g = np.random.default_rng(seed)
    f = np.fft.fftfreq(n) * n / 96  # the same grain at either period
    low = np.exp(-(f[:, None] ** 2 + f[None, :] ** 2) / (2 * 0.08 ** 2))[..., None]
    pic = np.fft.ifft2(np.fft.fft2(g.standard_normal((n, n, 3)), axes=(0, 1)) * low,
                       axes=(0, 1)).real[:96, :96]
    return (0.5 + 0.15 * pic / pic.std()).astype(np.float32)


def test_seam_measures_on_a_seamless_field_and_on_a_cut_one():
    """The step ratio singles out a wrap whose edges do not belong together; the band
    patch-SWD of a seamless wrap lies among those of the interior lines (it varies with
    what a band crosses: docs/synthesis.md)."""
    ref = _field(True, seed=1)  # another draw of the field: no patch is an exact copy
    for seamless in (True, False):
        pic = _field(seamless)
        wrap, inside, spread = base.seam_swd(pic, ref, band=8, lines=8)
        assert spread.shape == (7,)
        assert np.isclose(inside, spread[[1, 3, 5]].mean())  # the lines at 1/4, 1/2, 3/4
        assert wrap == base.seam_swd(pic, ref, band=8)[0]
        if seamless:
            assert spread.min() <= wrap <= spread.max() and base.seam(pic) < 1.3
        else:
            assert base.seam(pic) > 3


def test_repetition_reads_the_texture_not_the_canvas():
    """A texture with a 100 px period reads 1 on a 256 px and on a 512 px canvas, where the
    circular measure read it 0.64 and 0.83 (its canvas's wrap cuts the period): the bias that
    made a continued tile look closer to the 2 x 2 tiling than to its input. A random field
    reads low and its 2 x 2 tiling 1 under both."""
    from scipy.ndimage import gaussian_filter

    g = np.random.default_rng(0)
    tile = gaussian_filter(g.random((100, 100, 3)), (3, 3, 0), mode="wrap")
    periodic = np.tile(tile, (6, 6, 1))
    small, large = periodic[:256, :256], periodic[:512, :512]
    assert base.repetition(small) > 0.999 and base.repetition(large) > 0.999
    assert base.repetition_circular(small) < 0.7 < 0.8 < base.repetition_circular(large)
    field = gaussian_filter(g.random((256, 256, 3)), (3, 3, 0), mode="wrap")
    for measure in (base.repetition, base.repetition_circular):
        assert measure(field) < 0.2
        assert measure(base.tiling(field, (512, 512))) > 0.999
        assert measure(base.tiling(field, (256, 768))) > 0.999
    # the shift range: at least MIN_SHIFT, at most half the side (a 40 px period in a 64 px
    # picture counts, a 10 px one does not)
    stripes = np.sin(2 * np.pi * np.arange(64) / 10)[None, :, None] * np.ones((64, 1, 3))
    assert base.repetition(stripes) > 0.99  # 20 px: twice the period
    lone = np.zeros((64, 64, 3))
    lone[20:30, 20:30] = 1.0  # one square: no shift puts it on itself (nor flat ground on
    assert base.repetition(lone) < 0.2  # flat ground: that correlates with nothing)
    assert base.repetition(np.full((64, 64, 3), 0.5)) == 0.0  # flat: nothing to correlate


def test_scores_of_several_seeds_are_averaged_per_method_and_measure():
    """eval_synthesis --seeds: every method's patch-SWD, Gram and repetition are the mean of
    its seeds' (the summary counts wins on those means)."""
    import eval_synthesis

    runs = [{"ours": {"swd": 1.0, "gram": 0.2, "rep": 0.1},
             "random": {"swd": 19.0, "gram": 0.4, "rep": 0.3}},
            {"ours": {"swd": 3.0, "gram": 0.4, "rep": 0.3},
             "random": {"swd": 1.0, "gram": 0.2, "rep": 0.1}}]
    import pytest

    mean = eval_synthesis.mean_scores(runs)
    assert mean == {"ours": {"swd": 2.0, "gram": pytest.approx(0.3), "rep": pytest.approx(0.2)},
                    "random": {"swd": 10.0, "gram": pytest.approx(0.3),
                               "rep": pytest.approx(0.2)}}


def test_summary_counts_wins_over_the_stronger_random_placement():
    """ours must beat random placement of the same elements and of their whole groups
    (random_g) to count in the stronger line; the same-elements line counts the first only.
    Repetition counts, per measure, the textures where ours is not closer to the tiling's
    value than to the input's."""
    import eval_synthesis

    def sc(ours, rand, rand_g, rep):
        out = {m: {"swd": 1.0, "gram": 0.1, "rep": 1.0, "rep_c": 1.0}
               for m in eval_synthesis.METHODS}
        out["ours"]["swd"], out["random"]["swd"], out["random_g"]["swd"] = ours, rand, rand_g
        out["ours"]["rep"], out["ours"]["rep_c"] = rep
        return out

    results = [{"size": (8, 8), "sc": sc(1.0, 2.0, 0.5, (0.5, 0.79)), "per_seed": [(1.0, 2.0)],
                "rep_in": {"rep": 0.4, "rep_c": 0.6}, "seconds": 1.0},
               {"size": (8, 8), "sc": sc(1.0, 2.0, 3.0, (0.75, 0.75)), "per_seed": [(1.0, 2.0)],
                "rep_in": {"rep": 0.4, "rep_c": 0.6}, "seconds": 1.0}]
    text = "\n".join(eval_synthesis.summary(results))
    assert "ours < random placement on patch-SWD: 2/2" in text
    assert "whole groups (random_g), on patch-SWD: 1/2" in text
    # rep: 0.5 is nearer 0.4 than 1.0, 0.75 nearer 1.0; circular: 0.79 and 0.75 nearer 0.6
    assert "input's: 1/2 (circular autocorrelation, biased by the canvas: 2/2)" in text
    # an input that repeats exactly: input, tiling and ours read 1 to the last bits, a tie
    tie = {"sc": sc(1.0, 2.0, 3.0, (1.0, 1.0)), "rep_in": {"rep": 1 - 2e-16, "rep_c": 1.0}}
    tie["sc"]["tiling"]["rep"] = 1 + 2e-16
    assert eval_synthesis.not_repeating(tie)
    tie["rep_in"]["rep"], tie["sc"]["tiling"]["rep"] = 0.9, 1.0
    tie["sc"]["ours"]["rep"] = 0.9502  # nearer the tiling by 0.0004: below the precision
    assert eval_synthesis.not_repeating(tie)
    tie["sc"]["ours"]["rep"] = 0.952  # by 0.004
    assert not eval_synthesis.not_repeating(tie)


def test_cvt_line_measures_pass_seamless_tiles_and_flag_cut_ones():
    """eval_synthesis --seam-only scores tiles with cvt's line statistics as well: seam line
    against its neighbours, pooled over several tiles (seeds). Whole periods of a random
    field read as seamless, tiles cut from a longer period as seams, and the summary counts
    them."""
    import eval_cvt_seam
    import eval_synthesis

    def tile(seamless: bool) -> dict:
        pics = [_field(seamless, seed=s) for s in range(3)]
        return {"seeds": 3, "lines": [eval_cvt_seam.lines_of(p, ("colour step",))
                                      for p in pics],
                "cut": [eval_cvt_seam.lines_of(eval_synthesis.misaligned(p, 4),
                                               ("colour step",)) for p in pics]}

    whole, cut = tile(True), tile(False)
    step = "colour step"
    ok, null, shifted = eval_synthesis.line_ratios(whole, rolls=200, measures=(step,))[step]
    bad = eval_synthesis.line_ratios(cut, rolls=200, measures=(step,))[step][0]
    assert ok <= 1.1 < bad and shifted > 1.1  # the tiles cut out of register: a seam
    assert null.shape == (200,) and 0.8 < np.median(null) < 1.2  # rolled: no seam
    for t in (whole, cut):
        t["ratios"] = eval_synthesis.line_ratios(t, rolls=200, measures=(step,))
    text = eval_synthesis._pooled_lines([whole, cut], step)
    assert "within 1.1 on 1/2 textures" in text


def test_the_inputs_own_wrap_is_read_by_the_same_line_statistics():
    """A picture of whole periods wraps seamlessly; one cut from a longer period does not, and
    the reference says so (eval_synthesis --seam-only prints it beside ours)."""
    import eval_synthesis

    whole = eval_synthesis.input_wrap(_field(True))
    cut = eval_synthesis.input_wrap(_field(False))
    assert set(whole) == {"colour step", "colour step in phase", "patch SWD"}
    for m in ("colour step", "colour step in phase"):  # no period in a random field
        assert whole[m] <= 1.1 < cut[m]
    text = eval_synthesis.seam_text({"seam": 1.0, "seam_swd": 0.1, "inner_swd": 0.1,
                                     "inner_lines": np.array([0.1, 0.2]), "rank": 1,
                                     "ratios": {}, "input": whole})
    assert f"colour step {whole['colour step']:.2f}" in text.split("the input's own wrap: ")[1]
