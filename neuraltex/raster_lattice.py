"""A picture's lattice: the two shortest shifts under which it repeats (nearly) exactly.

Many texture pictures are a small tile repeated (a pattern library's tiles, fabric, parquet,
floor tiles); arranged like irregular textures, their grid falls apart. The test is the
normalized cross-correlation of the picture (colour, mean removed) with itself shifted by d,

    ncc(d) = sum_p x(p) . x(p + d) / sqrt(sum_p |x(p)|^2  sum_p |x(p + d)|^2),

both sums over the overlap of the picture and its shifted copy, so a shift under which the
overlap repeats exactly scores 1 whatever its size. A period is a local maximum with
ncc >= ``MIN_NCC``, at least ``MIN_PERIOD_PX`` long, seen at least ``MIN_REPEATS`` times along
its direction, and apart from the central lobe (a smooth picture correlates with itself at
small shifts; between 0 and a period the correlation must fall by ``LOBE_DROP``). The lattice
is the shortest period and the shortest one across it (Lagrange-Gauss reduced); with one only
(stripes), there is none. A period is refined to sub-pixel (a parabola through the peak and
its neighbours) unless the picture repeats exactly under the whole shift.
"""

from __future__ import annotations

import numpy as np

MIN_NCC = 0.9
MIN_PERIOD_PX = 8
MIN_REPEATS = 2  # copies of the period along its own direction inside the picture
LOBE_DROP = 0.3
MIN_SINE = 0.5  # the second period's angle to the first: at least 30 degrees
MAX_SIDE = 1024  # larger pictures are analysed on a strided copy
EXACT = 1 - 1e-6  # a tile repeated to the pixel: its period is that whole shift, not refined


def self_correlation(image: np.ndarray) -> np.ndarray:
    """ncc(d) of a picture (H, W, C) for every shift d = (dy, dx), |dy| < H, |dx| < W, indexed
    modulo (2H, 2W). Shape: -> (2H, 2W)."""
    x = image.astype(np.float64) - image.reshape(-1, image.shape[-1]).mean(0)
    h, w = x.shape[:2]
    s = (2 * h, 2 * w)

    def corr(f: np.ndarray, g: np.ndarray) -> np.ndarray:  # sum_p f(p) g(p + d), channels summed
        ff = np.fft.rfft2(f, s=s, axes=(0, 1))
        gg = np.fft.rfft2(g, s=s, axes=(0, 1))
        prod = np.conj(ff) * gg
        return np.fft.irfft2(prod.sum(-1) if prod.ndim == 3 else prod, s=s)

    energy = (x ** 2).sum(-1)
    ones = np.ones((h, w))
    num = corr(x, x)
    e_a, e_b = corr(energy, ones), corr(ones, energy)
    return num / np.sqrt(np.clip(e_a * e_b, 1e-12, None))


def raster_lattice(image: np.ndarray) -> np.ndarray | None:
    """The picture's lattice in pixels, rows (a, b) as (x, y), or None when it does not repeat.
    Shape: image (H, W, C) in [0, 1] -> (2, 2)."""
    stride = max(1, int(np.ceil(max(image.shape[:2]) / MAX_SIDE)))
    img = image[::stride, ::stride]
    if img.ndim == 2:
        img = img[..., None]
    h, w = img.shape[:2]
    if min(h, w) < MIN_REPEATS * MIN_PERIOD_PX:
        return None
    ncc = self_correlation(img)
    peaks = _periods(ncc, h, w)
    if not len(peaks):
        return None
    a = peaks[0]
    cross = np.abs(a[0] * peaks[:, 1] - a[1] * peaks[:, 0])
    across = cross >= MIN_SINE * np.linalg.norm(a) * np.linalg.norm(peaks, axis=1)
    if not across.any():
        return None
    b = peaks[np.argmax(across)]
    return _reduced(np.stack([a, b])) * stride


def _periods(ncc: np.ndarray, h: int, w: int) -> np.ndarray:
    """Shifts (x, y) that pass the period tests, shortest first, refined to sub-pixel unless
    the picture repeats exactly under the whole shift. Shape: -> (P, 2)."""
    dy = np.r_[np.arange(h), np.arange(-h, 0)][:, None]  # (2H, 1) shift of each row index
    dx = np.r_[np.arange(w), np.arange(-w, 0)][None]  # (1, 2W)
    size = np.hypot(dx, dy)
    # at least MIN_REPEATS copies along the shift, half-plane (d and -d are one period)
    fits = (np.abs(dx) * MIN_REPEATS <= w) & (np.abs(dy) * MIN_REPEATS <= h)
    half = (dy > 0) | ((dy == 0) & (dx > 0))
    high = ncc >= MIN_NCC
    local = np.ones_like(high)
    for sy in (-1, 0, 1):
        for sx in (-1, 0, 1):
            if sy or sx:
                local &= ncc >= np.roll(ncc, (sy, sx), axis=(0, 1))
    ys, xs = np.nonzero(high & local & fits & half & (size >= MIN_PERIOD_PX))
    order = np.argsort(size[ys, xs], kind="stable")
    out = []
    for y, x in zip(ys[order], xs[order], strict=True):
        d = np.array([dx[0, x], dy[y, 0]], float)
        if _valley(ncc, d) <= ncc[y, x] - LOBE_DROP:
            out.append(d if ncc[y, x] >= EXACT else d + _subpixel(ncc, y, x))
    return np.array(out).reshape(-1, 2)


def _valley(ncc: np.ndarray, d: np.ndarray) -> float:
    """The lowest ncc on the segment from 0 to the shift d = (x, y), at whole pixels."""
    n = int(np.ceil(np.abs(d).max()))
    t = np.arange(1, n) / n
    ys = np.round(t * d[1]).astype(int) % ncc.shape[0]
    xs = np.round(t * d[0]).astype(int) % ncc.shape[1]
    return float(ncc[ys, xs].min()) if n > 1 else 1.0


def _subpixel(ncc: np.ndarray, y: int, x: int) -> np.ndarray:
    """(x, y) offset of the parabola's vertex through the peak and its neighbours, per axis."""
    out = []
    for i, j in ((0, 1), (1, 0)):  # along x, then along y
        lo = ncc[(y - i) % ncc.shape[0], (x - j) % ncc.shape[1]]
        hi = ncc[(y + i) % ncc.shape[0], (x + j) % ncc.shape[1]]
        mid = ncc[y, x]
        den = lo - 2 * mid + hi
        out.append(float(np.clip(0.5 * (lo - hi) / den, -0.5, 0.5)) if den < -1e-12 else 0.0)
    return np.array(out)


def _reduced(basis: np.ndarray) -> np.ndarray:
    """Lagrange-Gauss reduction: the shortest basis of the same lattice. Shape: (2, 2)."""
    a, b = basis.astype(float)
    if a @ a > b @ b:
        a, b = b, a
    while True:
        k = round((a @ b) / (a @ a))
        b = b - k * a
        if b @ b >= a @ a:
            return np.stack([a, b]) + 0.0  # no negative zeros
        a, b = b, a


def repeats_exactly(image: np.ndarray, basis: np.ndarray, tol: float = 1e-6) -> bool:
    """Whether the picture (H, W, C) equals itself shifted by each period of ``basis`` (2, 2),
    rows (x, y) in pixels, over the overlap: whole-pixel periods of a tile repeated to the
    pixel, under which copies of the picture continue each other."""
    if not np.allclose(basis, np.round(basis), atol=1e-9):
        return False
    h, w = image.shape[:2]
    for dx, dy in np.round(basis).astype(int):
        if dy < 0:
            dx, dy = -dx, -dy
        if abs(dx) >= w or dy >= h:
            return False
        a = image[dy:, max(dx, 0):w + min(dx, 0)]
        b = image[:h - dy, max(-dx, 0):w - max(dx, 0)]
        if np.abs(a.astype(np.float64) - b).max() > tol:
            return False
    return True
