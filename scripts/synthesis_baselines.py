"""Baselines and metrics of ``scripts/eval_synthesis.py`` (no downloaded weights anywhere).

Baselines, each at the output size:
- ``tiling``: the input repeated (2 x 2 for 512 px from 256 px), cropped;
- ``random placement``: the elements ours arranged (texton groups, or textons alone), as many
  per area as in the input, at uniform random positions, over the same stretched background
  layer, same decoder, then the same paste of the reconstruction's pixels as ours;
- ``quilting``: image quilting (Efros and Freeman, SIGGRAPH 2001): square blocks in raster
  order, each the best-matching input block on its overlaps (within ``TOLERANCE`` of the best
  error, or among the ``CHOICES`` best, chosen at random), joined along the minimum-error
  boundary cut.

Metrics:
- ``swd``: multi-scale patch sliced Wasserstein distance to the input (cvt.metrics.patch_swd);
- ``gram``: texture statistics distance, relative Frobenius distance of the Gram matrices of a
  fixed-seed random shallow CNN (3 conv layers, ReLU, average pooling), averaged over layers;
- ``repetition``: the highest correlation (Pearson, over the overlap) of the grey picture with
  itself shifted by at least ``MIN_SHIFT`` px and at most half its side along each axis: 1 for
  an exact repeat, low for none. No wrap-around, so it reads the texture, not the canvas: a
  periodic texture reads the same on any canvas (``repetition_circular``, the measure used
  before, reads a 100 px period 0.6-0.7 on a 256 px canvas and higher on a 512 px one,
  because the canvas's own wrap cuts the period);
- ``repetition_circular``: the highest circular autocorrelation of the grey, mean-removed
  picture at offsets of at least ``MIN_SHIFT`` px;
- ``seam``: for a tileable picture, the mean absolute step across the wrap (last to first
  column and row) over the mean step between neighbouring pixels inside.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from cvt.metrics import patch_swd

BLOCK, OVERLAP, STRIDE, TOLERANCE = 48, 8, 3, 0.1  # quilting, pixels
CHOICES = 4  # quilting: candidate blocks at least
MIN_SHIFT = 16  # repetition: smallest offset considered, pixels


# ------------------------------------------------------------------------------ baselines
def tiling(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The input (H, W, 3) repeated and cropped to ``size`` = (H', W')."""
    h, w = image.shape[:2]
    reps = (-(-size[0] // h), -(-size[1] // w), 1)
    return np.tile(image, reps)[: size[0], : size[1]]


def random_placement(textons, rows, groups: list[list[int]], size: tuple[int, int], short: int,
                     seed: int = 0):
    """Placements (element, dx, dy) of the elements ``groups`` (positions into the texton
    indices ``rows``: ours' elements) with their centres (the mean of their textons' mu) at
    uniform random points of the output canvas, as many per area as in the input (for
    neuraltex.texton_synthesis.place and paste_arranged)."""
    g = np.random.default_rng(seed)
    w, h = size[1] / short, size[0] / short
    cw, ch = textons.canvas
    n = round(len(groups) * w * h / (cw * ch))
    pick = g.integers(len(groups), size=n)
    mu = textons.mu[0].detach().cpu().numpy()[np.asarray(rows)]  # (E, 2)
    centre = np.stack([mu[groups[k]].mean(0) for k in pick]) if n else np.zeros((0, 2))
    to = g.uniform([0, 0], [w, h], size=(n, 2))
    return [(int(k), float(t[0] - m[0]), float(t[1] - m[1]))
            for k, m, t in zip(pick, centre, to, strict=True)]


def _overlap_errors(image: np.ndarray, out: np.ndarray, y: int, x: int, b: int) -> np.ndarray:
    """SSD of every input block (top-left on a STRIDE grid) against the already filled left
    and top overlaps of the output block at (y, x). Shape: -> (ny, nx)."""
    from numpy.lib.stride_tricks import sliding_window_view

    ny, nx = (image.shape[0] - b) // STRIDE + 1, (image.shape[1] - b) // STRIDE + 1
    err = np.zeros((ny, nx), np.float32)
    for used, shape, target in ((x > 0, (b, OVERLAP), out[y:y + b, x:x + OVERLAP]),
                                (y > 0, (OVERLAP, b), out[y:y + OVERLAP, x:x + b])):
        if used:
            win = sliding_window_view(image, shape, axis=(0, 1))[::STRIDE, ::STRIDE][:ny, :nx]
            err += ((win - target.transpose(2, 0, 1)[None, None]) ** 2).sum(axis=(2, 3, 4))
    return err


def _min_cut(err: np.ndarray) -> np.ndarray:
    """Boolean mask (h, w) of pixels left of the vertical minimum-error path through the
    error surface ``err`` (h, w) (dynamic programming, Efros-Freeman sec. 2.1)."""
    h, w = err.shape
    cost = err.copy()
    for i in range(1, h):
        left = np.r_[np.inf, cost[i - 1, :-1]]
        right = np.r_[cost[i - 1, 1:], np.inf]
        cost[i] += np.minimum(np.minimum(left, cost[i - 1]), right)
    path = np.zeros(h, int)
    path[-1] = int(np.argmin(cost[-1]))
    for i in range(h - 2, -1, -1):
        j = path[i + 1]
        lo, hi = max(j - 1, 0), min(j + 2, w)
        path[i] = lo + int(np.argmin(cost[i, lo:hi]))
    return np.arange(w)[None] < path[:, None]


def quilting(image: np.ndarray, size: tuple[int, int], seed: int = 0) -> np.ndarray:
    """Image quilting of the input (H, W, 3) in [0, 1] to ``size`` = (H', W')."""
    g = np.random.default_rng(seed)
    b, step = BLOCK, BLOCK - OVERLAP
    H, W = size
    ny, nx = -(-(H - OVERLAP) // step), -(-(W - OVERLAP) // step)
    out = np.zeros((ny * step + OVERLAP, nx * step + OVERLAP, 3), np.float32)
    image = image.astype(np.float32)
    for i in range(ny):
        for j in range(nx):
            y, x = i * step, j * step
            err = _overlap_errors(image, out, y, x, b)
            # within TOLERANCE of the best (Efros-Freeman), but never fewer than CHOICES
            # blocks: on flat areas the best error is ~0 and one block would repeat forever
            limit = max(err.min() * (1 + TOLERANCE), np.partition(err.ravel(), CHOICES)[CHOICES])
            ok = np.argwhere(err <= limit)
            sy, sx = ok[g.integers(len(ok))] * STRIDE
            block = image[sy:sy + b, sx:sx + b]
            keep = np.ones((b, b), bool)  # True: take the new block
            if x:
                e = ((block[:, :OVERLAP] - out[y:y + b, x:x + OVERLAP]) ** 2).sum(-1)
                keep[:, :OVERLAP] &= ~_min_cut(e)
            if y:
                e = ((block[:OVERLAP] - out[y:y + OVERLAP, x:x + b]) ** 2).sum(-1)
                keep[:OVERLAP] &= ~_min_cut(e.T).T
            region = out[y:y + b, x:x + b]
            region[keep] = block[keep]
    return out[:H, :W].astype(np.float32)


# -------------------------------------------------------------------------------- metrics
def swd(a: np.ndarray, b: np.ndarray) -> float:
    return patch_swd(a, b)


def _random_cnn() -> torch.nn.Module:
    g = torch.Generator().manual_seed(0)
    layers = []
    for cin, cout in ((3, 32), (32, 64), (64, 64)):
        conv = torch.nn.Conv2d(cin, cout, 3, padding=1)
        with torch.no_grad():
            conv.weight.copy_(torch.randn(conv.weight.shape, generator=g) / (3 * cin ** 0.5))
            conv.bias.zero_()
        layers.append(conv)
    return torch.nn.ModuleList(layers).eval()


_CNN = _random_cnn()


def _grams(image: np.ndarray) -> list[torch.Tensor]:
    x = torch.from_numpy(np.ascontiguousarray(image, np.float32)).permute(2, 0, 1)[None]
    x = (x - 0.5) / 0.25
    out = []
    with torch.no_grad():
        for k, conv in enumerate(_CNN):
            x = F.relu(conv(x))
            f = x.flatten(2)[0]  # (C, HW)
            out.append(f @ f.T / f.shape[1])  # (C, C)
            if k < len(_CNN) - 1:
                x = F.avg_pool2d(x, 2)
    return out


def gram_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Mean over layers of |G_a - G_b|_F / |G_a|_F (``a``: the reference)."""
    return float(np.mean([float((ga - gb).norm() / ga.norm().clamp_min(1e-12))
                          for ga, gb in zip(_grams(a), _grams(b), strict=True)]))


def repetition(image: np.ndarray) -> float:
    """Highest correlation of the grey picture (H, W, 3) with itself shifted by (dy, dx),
    hypot(dy, dx) >= MIN_SHIFT, |dy| <= H / 2, |dx| <= W / 2: Pearson's r over the pixels
    both cover (at least a quarter of the picture), with that overlap's own means and
    deviations (the lattice detector's ncc, neuraltex.raster_lattice, removes the picture's
    mean instead, so an overlap on flat ground reads 1 there; here it reads 0). All sums over
    the overlaps come from zero-padded FFT correlations."""
    grey = image.mean(-1).astype(np.float64)
    grey = grey - grey.mean()
    h, w = grey.shape
    shape = (2 * h, 2 * w)  # no wrap-around for any shift

    def spec(x: np.ndarray) -> np.ndarray:
        return np.fft.rfft2(x, s=shape)

    def corr(fa: np.ndarray, fb: np.ndarray) -> np.ndarray:  # sum_p a[p] b[p + d], (2h, 2w)
        return np.fft.irfft2(np.conj(fa) * fb, s=shape)

    f1, fx, fxx = spec(np.ones_like(grey)), spec(grey), spec(grey * grey)
    n = np.maximum(corr(f1, f1), 1.0)
    s1, s2 = corr(fx, f1), corr(f1, fx)  # sums of the unshifted / shifted pixels in overlap
    q1, q2 = corr(fxx, f1), corr(f1, fxx)
    cov = corr(fx, fx) - s1 * s2 / n
    var = np.maximum(q1 - s1 * s1 / n, 0) * np.maximum(q2 - s2 * s2 / n, 0)
    r = cov / np.sqrt(np.maximum(var, 1e-24))
    dy = np.minimum(np.arange(2 * h), 2 * h - np.arange(2 * h))[:, None]  # (2h, 1) |shift|
    dx = np.minimum(np.arange(2 * w), 2 * w - np.arange(2 * w))[None]
    keep = (np.hypot(dy, dx) >= MIN_SHIFT) & (dy <= h // 2) & (dx <= w // 2)
    return float(min(r[keep].max(), 1.0))


def repetition_circular(image: np.ndarray) -> float:
    """Highest circular autocorrelation (normalized to 1 at offset 0) at offsets >= MIN_SHIFT
    (the repetition measure of sessions 13-19; biased by the canvas: see the module doc)."""
    grey = image.mean(-1)
    grey = grey - grey.mean()
    spec = np.fft.rfft2(grey)
    ac = np.fft.irfft2(spec * np.conj(spec), s=grey.shape)
    ac /= max(ac[0, 0], 1e-12)
    h, w = grey.shape
    dy = np.minimum(np.arange(h), h - np.arange(h))[:, None]
    dx = np.minimum(np.arange(w), w - np.arange(w))[None]
    far = np.hypot(dy, dx) >= MIN_SHIFT
    return float(ac[far].max())


def seam(image: np.ndarray) -> float:
    """Mean |step| across the wrap (last -> first column and row) / mean |step| inside."""
    across = np.r_[np.abs(image[:, -1] - image[:, 0]).ravel(),
                   np.abs(image[-1] - image[0]).ravel()].mean()
    inside = np.r_[np.abs(np.diff(image, axis=1)).ravel(),
                   np.abs(np.diff(image, axis=0)).ravel()].mean()
    return float(across / max(inside, 1e-12))


def seam_swd(image: np.ndarray, reference: np.ndarray, band: int = 16,
             lines: int = 0) -> tuple[float, float] | tuple[float, float, np.ndarray]:
    """(patch-SWD to ``reference`` of the bands straddling the wrap (the picture rolled by
    half), mean of those of the bands straddling the lines at 1/4, 1/2 and 3/4 inside);
    with ``lines`` also the patch-SWD of the bands at k / lines inside, k = 1 .. lines - 1
    (how much a band's score varies with what it happens to cross)."""
    h, w = image.shape[:2]

    def bands(x: np.ndarray, f: float) -> np.ndarray:
        x = np.roll(x, (round(h * (0.5 - f)), round(w * (0.5 - f))), axis=(0, 1))
        v = x[:, w // 2 - band:w // 2 + band]  # (h, 2 band, 3)
        hz = x[h // 2 - band:h // 2 + band].transpose(1, 0, 2)  # (w, 2 band, 3)
        return np.concatenate([v, hz], 0)

    scores: dict[float, float] = {}  # band position -> its patch-SWD, each scored once

    def score(f: float) -> float:
        if f not in scores:
            scores[f] = swd(reference, bands(image, f))
        return scores[f]

    wrap, inside = score(0.0), float(np.mean([score(f) for f in (0.25, 0.5, 0.75)]))
    if not lines:
        return wrap, inside
    return wrap, inside, np.array([score(k / lines) for k in range(1, lines)])
