"""Resolution-independent value noise and fBm, sampled at normalized coordinates.

The lattice values are drawn from the caller's generator and depend only on the
extent of the domain (in normalized units, short side = 1), never on the pixel
count: rendering the same sample at 128 px or 512 px gives the same field.
"""

from __future__ import annotations

import numpy as np


def value_noise(rng: np.random.Generator, x: np.ndarray, y: np.ndarray, freq: float,
                extent: tuple[float, float]) -> np.ndarray:
    """Smooth value noise in [-1, 1] with ``freq`` lattice cells per normalized unit.

    Shape: ``x`` (1, W) or (H, W), ``y`` (H, 1) or (H, W) -> (H, W) float32.
    ``extent`` = (width, height) of the domain in normalized units; it fixes the lattice size.
    """
    gw = int(np.ceil(extent[0] * freq)) + 2
    gh = int(np.ceil(extent[1] * freq)) + 2
    lattice = rng.uniform(-1.0, 1.0, size=(gh, gw)).astype(np.float32)  # (gh, gw)
    if x.ndim == 2 and x.shape[0] == 1 and y.ndim == 2 and y.shape[1] == 1:
        # Separable grid: interpolate along x for every lattice row, then along y.
        rows = _lerp_axis(lattice, x[0] * freq, gw, axis=1)  # (gh, W)
        return _lerp_axis(rows, y[:, 0] * freq, gh, axis=0)  # (H, W)
    fx, fy = x * freq, y * freq
    ix = np.clip(np.floor(fx).astype(np.int64), 0, gw - 2)
    iy = np.clip(np.floor(fy).astype(np.int64), 0, gh - 2)
    tx, ty = _smoothstep(fx - ix), _smoothstep(fy - iy)
    ix, iy = np.broadcast_arrays(ix, iy)
    tx, ty = np.broadcast_arrays(tx, ty)
    v00, v01 = lattice[iy, ix], lattice[iy, ix + 1]
    v10, v11 = lattice[iy + 1, ix], lattice[iy + 1, ix + 1]
    top = v00 + (v01 - v00) * tx
    bottom = v10 + (v11 - v10) * tx
    return (top + (bottom - top) * ty).astype(np.float32)


def _lerp_axis(values: np.ndarray, f: np.ndarray, n: int, axis: int) -> np.ndarray:
    i = np.clip(np.floor(f).astype(np.int64), 0, n - 2)
    t = _smoothstep(f - i)
    a, b = np.take(values, i, axis=axis), np.take(values, i + 1, axis=axis)
    t = t[None, :] if axis == 1 else t[:, None]
    return (a + (b - a) * t).astype(np.float32)


def fbm(rng: np.random.Generator, x: np.ndarray, y: np.ndarray, freq: float,
        extent: tuple[float, float], octaves: int = 4, gain: float = 0.5) -> np.ndarray:
    """Fractal Brownian motion: ``octaves`` of value noise, each twice the frequency.

    Returns (H, W) float32, roughly zero mean with values in [-1, 1].
    """
    if octaves < 1:
        raise ValueError(f"octaves must be >= 1, got {octaves}")
    total, norm, amp = 0.0, 0.0, 1.0
    for k in range(octaves):
        total = total + amp * value_noise(rng, x, y, freq * 2**k, extent)
        norm += amp
        amp *= gain
    return (total / norm).astype(np.float32)


def _smoothstep(t: np.ndarray) -> np.ndarray:
    return (t * t * (3.0 - 2.0 * t)).astype(np.float32)
