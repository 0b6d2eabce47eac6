"""The seam of a tileable output: patch SWD across the tile's seam lines against interior lines.

Tiled 2 x 2, a tile shows its wrap lines (x = 0 and y = 0 of the tile, a torus) as the seams;
every other line of the tile is an interior line. For one line the measure is the patch SWD
(x 1000, octaves summed, as cvt.metrics.patch_swd) between the patches that straddle it and
the patches right beside it on both sides, on the same rows (columns): a line through
continuous content has straddling patches like their neighbours; across a seam they hold cut
motifs, steps and doubled copies that neither side shows. The seam's value pools both seam
lines over their full length; the interior's is the mean over many control lines, every
``STEP`` px in both directions, far enough from the seam that their side patches do not reach
it. All lines use the same fixed projections. :func:`seam_ratio` pools several tiles (the
outputs of several seeds): one seam per tile is one sample of a statistic that varies from
line to line with what it crosses.

On an exactly periodic image (a lattice whose cell divides the tile) a line's value depends
on where in the cell it runs, so the controls are the lines at the image's own near-periods
(:func:`periods`): the lines that should look exactly like the seam.

One tile's seam is two lines, and a line's value varies with what it crosses (coefficient of
variation 0.4-0.7 from line to line), so the pooled ratio resolves 10 % only over many seeds.
:func:`seam_test` asks instead whether the seam is shown worse than 1.1 x the interior, against
the same tiles rolled (:func:`rolled_ratios`, seamless by construction) scaled by 1.1;
:func:`detectable` is the seam factor it flags 9 times in 10 (docs/cvt_real_eval.md).

Compared with all the patches of the tile (as the previous measure did, with 64 px strips) a
line reads what motifs it crosses: from line to line its value varied with a coefficient of
variation of 0.8-1.1 on the emoji outputs, and seam / interior did not separate tiles from
plain outputs. Compared with its own neighbours it reads mostly the step across it
(docs/cvt_real_eval.md has both columns).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F

OCTAVES = 3
PATCH = 4  # taps per side of a patch, spaced 2**s px at octave s
PROJECTIONS = 64
STEP = 8  # control lines every STEP px
MARGIN = 2 * (PATCH - 1) * 2 ** (OCTAVES - 1)  # px: side patches of a control miss the seam
PERIOD_TOL = 0.02  # a shift is a near-period when its mean squared difference is this small
# patch starts, in taps from the line: straddling it; wholly left of it and wholly right of it
_ON = -np.arange(1, PATCH)
_BESIDE = np.r_[-np.arange(PATCH, 2 * PATCH - 1), np.arange(PATCH - 1)]


def _projected(image: np.ndarray, seed: int = 0) -> list[torch.Tensor]:
    """Per octave, the projections of the patch starting at every pixel (dilated taps over a
    box-filtered image, wrapping around). Shape: (H, W, 3) -> OCTAVES x (P, H, W)."""
    x = torch.from_numpy(np.ascontiguousarray(image, np.float32)).permute(2, 0, 1)[None]
    gen = torch.Generator().manual_seed(seed)
    out = []
    for s in range(OCTAVES):
        k = 2 ** s
        pad = k - 1 + (PATCH - 1) * k
        xp = torch.cat([x, x[..., :, :pad]], -1)
        xp = torch.cat([xp, xp[..., :pad, :]], -2)  # (1, 3, H + pad, W + pad)
        blur = F.avg_pool2d(xp, k, stride=1)  # mean over [y, y + k) x [x, x + k)
        p = F.unfold(blur, PATCH, dilation=k)[0]  # (3 * PATCH**2, H * W)
        dirs = torch.randn(p.shape[0], PROJECTIONS, generator=gen)
        dirs = dirs / dirs.norm(dim=0, keepdim=True)
        out.append((dirs.T @ p).reshape(PROJECTIONS, *image.shape[:2]))
    return out


def _swd(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Sliced W2^2 per set of two batches of projected sets, the larger's quantiles taken at
    the smaller's. Shape: (P, L, n), (P, L, m) -> (L,)."""
    a, b = torch.sort(a, -1).values, torch.sort(b, -1).values
    if b.shape[-1] != a.shape[-1]:
        b = F.interpolate(b, size=a.shape[-1], mode="linear", align_corners=True)
    return (a - b).square().mean((0, 2))


def line_swd(maps: list[torch.Tensor], axis: int, lines) -> np.ndarray:
    """Patch SWD x 1000 of the patches straddling each line against the patches beside it;
    axis 1: vertical lines between columns c - 1 and c, axis 0: horizontal. Shape: maps
    OCTAVES x (P, H, W), lines (L,) -> (L,)."""
    lines = np.asarray(lines)
    total = torch.zeros(len(lines))
    for s, q in enumerate(maps):
        k, n = 2 ** s, q.shape[1 + axis]
        qa = (q if axis == 1 else q.transpose(1, 2))[:, ::k]  # (P, m / k, n): along the line,
        # patches on the octave's grid
        sets = []
        for offs in (_ON, _BESIDE):
            idx = torch.from_numpy((lines[:, None] + offs[None] * k) % n)  # (L, o)
            v = qa[:, :, idx.reshape(-1)].reshape(len(q), qa.shape[1], len(lines), -1)
            sets.append(v.permute(0, 2, 1, 3).reshape(len(q), len(lines), -1))  # (P, L, m o)
        total += _swd(*sets)
    return 1000 * total.numpy()


def periods(image: np.ndarray, axis: int) -> np.ndarray:
    """Shifts t (0 < t < n) along ``axis`` under which the image, wrapped around, is nearly
    itself: mean squared difference <= PERIOD_TOL x its median over all shifts (FFT
    autocorrelation) and no more than at t +- 1. Empty for an irregular image. Shape:
    (H, W, 3) -> (T,)."""
    x = np.moveaxis(np.asarray(image, np.float64), axis, 0)  # (n, m, 3)
    f = np.fft.rfft(x, axis=0)
    auto = np.fft.irfft(np.abs(f) ** 2, n=len(x), axis=0).sum((1, 2))  # (n,)
    ssd = np.maximum(2 * (auto[0] - auto), 0)  # sum of squared differences per shift
    t = np.arange(1, len(x))
    low = ssd[t] <= PERIOD_TOL * np.median(ssd[t])
    lowest = (ssd[t] <= ssd[t - 1]) & (ssd[t] <= ssd[(t + 1) % len(x)])  # not its neighbours
    return t[low & lowest]


def controls(image: np.ndarray, axis: int) -> np.ndarray:
    """Interior lines to compare a seam with (axis 1: vertical lines, at columns; 0: rows): at
    least MARGIN px from it, at the image's near-periods along that axis if it has such lines,
    else every STEP px. Shape: (H, W, 3) -> (L,)."""
    n = image.shape[axis]
    t = periods(image, axis)
    t = t[np.minimum(t, n - t) >= MARGIN]
    if len(t):
        return t
    return np.arange(MARGIN, n - MARGIN + 1, STEP)


def seam_ratio(images: list[np.ndarray]) -> tuple[float, float]:
    """Patch SWD across the seam lines and the mean over interior lines, pooled over
    ``images`` (tiles of one exemplar, e.g. several seeds): sums over tiles of the mean of
    the vertical and horizontal value. Shape: each (H, W, 3) float in [0, 1]."""
    seam = inner = 0.0
    for image in images:
        maps = _projected(image)
        for axis in (1, 0):
            seam += float(line_swd(maps, axis, [0])[0]) / 2
            inner += float(line_swd(maps, axis, controls(image, axis)).mean()) / 2
    return seam, inner


def line_values(image: np.ndarray, every: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """:func:`line_swd` of every ``every``-th vertical and horizontal line of a tile (64 lines
    at a time). Shape: (H, W, 3) -> (W / every,), (H / every,)."""
    maps = _projected(image)
    return tuple(np.concatenate([line_swd(maps, axis, lines[k : k + 64])
                                 for k in range(0, len(lines), 64)])
                 for axis, lines in ((1, np.arange(0, image.shape[1], every)),
                                     (0, np.arange(0, image.shape[0], every))))


GRID = 2 ** (OCTAVES - 1)  # px between the lines the null reads (the coarsest tap spacing)
LEVEL = 0.95  # confidence of the seam test
MARGIN_RATIO = 1.1  # the target: seam within 10 % of the interior
NEAR = 8  # px: the colour step's controls, either side of the line
STEP_FLOOR = 1e-3  # a step below this (flat ground on both sides) reads as this


def tile_lines(images: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`line_values` of every GRID-th line of each tile, computed once for the seam's
    ratio and its null (:func:`ratios_at`). Shape: T x (H, W, 3) -> T x ((W/GRID,), (H/GRID,))."""
    return [line_values(image, GRID) for image in images]


def ratios_at(lines: list[tuple[np.ndarray, np.ndarray]], seams: np.ndarray) -> np.ndarray:
    """The pooled seam / interior ratio (as :func:`seam_ratio` for tiles without
    near-periods) with the seam of tile t, axis a at line ``seams[d, t, a]`` (in GRID steps;
    0: the tile's own seam) and its controls every STEP px from MARGIN to n - MARGIN beyond it.
    Shape: lines T x ((W/GRID,), (H/GRID,)), seams (D, T, 2) -> (D,)."""
    seams = np.asarray(seams)
    seam, inner = np.zeros(len(seams)), np.zeros(len(seams))
    for t, tile in enumerate(lines):
        for a, values in enumerate(tile):
            s, i = seam_and_inner(values, seams[:, t, a], GRID)
            seam += s / 2
            inner += i / 2
    return seam / inner


def seam_and_inner(values: np.ndarray, at: np.ndarray, every: int) -> tuple[np.ndarray, np.ndarray]:
    """A line's value and the mean of its controls (every STEP px from MARGIN to n - MARGIN
    beyond it), with the seam at line ``at``; ``values`` of every ``every``-th line of one
    tile axis (``every`` divides STEP). Shape: (n,), (D,) -> (D,), (D,)."""
    n = len(values)
    ctrl = np.arange(MARGIN, n * every - MARGIN + 1, STEP) // every  # (L,) in lines
    at = np.asarray(at)
    return values[at], values[(at[:, None] + ctrl[None]) % n].mean(1)


def rolled_ratios(images: list[np.ndarray], rolls: int = 200, seed: int = 0,
                  lines: list | None = None) -> np.ndarray:
    """The :func:`seam_ratio` of the same tiles rolled by random offsets (one offset pair per
    tile and draw, in GRID steps, so that the patches along a line fall on the same grid as
    in a rolled image): a seamless tile rolled is as seamless, and its seam is then a line of
    the tile's interior, so these ratios are what the estimator reads on these tiles where
    there is no seam by construction (its null distribution). ``lines``: :func:`tile_lines`
    of ``images`` if already computed. Tiles with near-periods are not supported (their
    controls depend on the seam's phase). Shape: each (H, W, 3) -> (rolls,)."""
    rng = np.random.default_rng(seed)
    lines = tile_lines(images) if lines is None else lines
    seams = np.stack([np.stack([rng.integers(0, len(v), rolls) for v in tile], -1)
                      for tile in lines], 1)  # (rolls, T, 2)
    return ratios_at(lines, seams)


def seam_test(ratio: float, null: np.ndarray, margin: float = MARGIN_RATIO) -> float:
    """p-value of "the seam is more than ``margin`` x the interior": the share of the
    seam-free draws ``null`` (:func:`rolled_ratios` of the same tiles) that, scaled by
    ``margin`` (a seam exactly ``margin`` x worse, everything else alike), read at least
    ``ratio``. Below 1 - LEVEL the seam is shown worse than ``margin`` x the interior."""
    return float(np.mean(margin * np.asarray(null) >= ratio))


def detectable(null: np.ndarray, margin: float = MARGIN_RATIO, power: float = 0.9) -> float:
    """The smallest seam factor f (seam lines f x the interior's) that :func:`seam_test`
    flags at LEVEL in ``power`` of draws: f x null exceeds margin x its LEVEL quantile."""
    null = np.asarray(null)
    return float(margin * np.quantile(null, LEVEL) / np.quantile(null, 1 - power))


def step_profile(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean colour step (summed over channels) across every vertical line (line c: between
    columns c - 1 and c, wrapping around, so line 0 is the seam of the image tiled) and every
    horizontal line. Shape: (H, W, 3) -> (W,), (H,)."""
    return tuple(np.abs(image - np.roll(image, 1, axis)).sum(2).mean(1 - axis)
                 for axis in (1, 0))


def _beside(near: int) -> np.ndarray:
    """Offsets of the lines 1 ... ``near`` px either side of a line. Shape: (2 near,)."""
    return np.r_[-np.arange(1, near + 1), np.arange(1, near + 1)]


def step_ratio(profile: np.ndarray, at: np.ndarray, near: int = NEAR,
               offsets: np.ndarray | None = None) -> np.ndarray:
    """The colour step across line ``at`` over the mean step across the lines 1 ... ``near``
    px either side of it: lines that cross nearly the same motifs, so the content a line
    crosses cancels out (a line's patch SWD against far controls varies with it, coefficient
    of variation 0.5-0.7; this ratio 0.2-0.5 on the emoji tiles). ``offsets``: the lines to
    compare with instead, relative to ``at`` (:func:`step_offsets`). Shape: (n,), (D,) -> (D,)."""
    at = np.asarray(at)
    side = _beside(near) if offsets is None else offsets
    ctrl = profile[(at[:, None] + np.asarray(side)[None]) % len(profile)].mean(1)
    return profile[at] / np.maximum(ctrl, STEP_FLOOR)


def step_offsets(image: np.ndarray, axis: int, near: int = NEAR) -> np.ndarray:
    """The lines a line's colour step is compared with, as offsets from it (axis 1: vertical
    lines, 0: horizontal): on an exactly periodic image (a lattice whose cell divides the
    tile) the image's near-periods (:func:`periods`), the lines that run at the same place
    in their cells and should look exactly like it (a line along a cell border crosses the
    border's grout or colour change, one a pixel beside it does not); else the lines 1 ...
    ``near`` px either side. Shape: (H, W, 3) -> (L,)."""
    t = periods(image, axis)
    return t if len(t) else _beside(near)


@dataclass(frozen=True)
class StepLines:
    """The colour step across every line of one tile axis (:func:`step_profile`) and the
    offsets of the lines each is compared with (:func:`step_offsets`); ``len`` is the number
    of lines, as for a profile."""

    profile: np.ndarray  # (n,)
    offsets: np.ndarray  # (L,)

    def __len__(self) -> int:
        return len(self.profile)


def step_lines(image: np.ndarray) -> tuple[StepLines, StepLines]:
    """:class:`StepLines` of the vertical and the horizontal lines. Shape: (H, W, 3)."""
    return tuple(StepLines(p, step_offsets(image, axis))
                 for p, axis in zip(step_profile(image), (1, 0), strict=True))


def phase_step_ratio(lines: StepLines, at: np.ndarray) -> np.ndarray:
    """:func:`step_ratio` against the lines at the same phase of the image's period where it
    has one (:func:`step_offsets`). Shape: (n,) lines, (D,) -> (D,)."""
    return step_ratio(lines.profile, at, offsets=lines.offsets)


def seam_step(image: np.ndarray, near: int = NEAR) -> tuple[float, float]:
    """Mean colour step across the seams of the image tiled 2 x 2, and the same across the
    lines within ``near`` pixels of them, on either side. Shape: (H, W, 3).

    A seam shows as a step all along the seam line (motifs cut there, gaps, doubled copies);
    in a seamless tiling the seam line is a line like its neighbours, so the two are about
    equal; an extra column beside :func:`seam_ratio`.
    """
    side = _beside(near)
    profiles = step_profile(image)
    return (float(np.mean([p[0] for p in profiles])),
            float(np.mean([p[side].mean() for p in profiles])))


def pooled_ratios(ratio, tiles: list, at: np.ndarray) -> np.ndarray:
    """Mean over tiles and axes of ``ratio(values, lines)`` (seam / interior of one tile
    axis, with the seam at ``lines``): each tile axis weighs the same, whatever the level of
    its values. ``tiles``: per tile the per-line values of both axes; ``at``: the seam line
    of tile t, axis a in draw d. Shape: T x ((n0,), (n1,)), at (D, T, 2) -> (D,)."""
    at = np.asarray(at)
    return np.mean([ratio(values, at[:, t, a]) for t, tile in enumerate(tiles)
                    for a, values in enumerate(tile)], axis=0)


def rolled_draws(tiles: list, rolls: int = 2000, seed: int = 0) -> np.ndarray:
    """Random seam lines for :func:`pooled_ratios` (the tiles rolled: no seam by
    construction). Shape: T x ((n0,), (n1,)) -> (rolls, T, 2)."""
    rng = np.random.default_rng(seed)
    return np.stack([np.stack([rng.integers(0, len(v), rolls) for v in tile], -1)
                     for tile in tiles], 1)


def misaligned(image: np.ndarray, shift: int) -> np.ndarray:
    """The tile with ``shift`` rows and columns cut off at its seam: tiled, the two sides of
    each seam are ``shift`` px out of register (a tile that does not wrap around).
    Shape: (H, W, 3) -> (H - shift, W - shift, 3)."""
    return image[shift:, shift:]
