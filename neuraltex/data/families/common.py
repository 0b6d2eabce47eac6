"""Pieces shared by the texture families: layouts, backgrounds, lighting, sensor noise."""

from __future__ import annotations

import numpy as np

from neuraltex.data.noise import fbm


def coords(h: int, w: int) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """Pixel-centre coordinates x (1, W), y (H, 1) and the extent (width, height), short side 1."""
    s = min(h, w)
    x = ((np.arange(w) + 0.5) / s).astype(np.float32)[None, :]
    y = ((np.arange(h) + 0.5) / s).astype(np.float32)[:, None]
    return x, y, (w / s, h / s)


def jittered_grid(rng: np.random.Generator, extent: tuple[float, float], cell: float,
                  jitter: float, presence: float = 1.0, stagger: bool = False) -> np.ndarray:
    """Texton centres on a jittered grid with a one-cell margin. Returns (N, 2) x, y.

    ``jitter`` in cells (0 = regular, 1 = one cell); ``presence`` drops cells at random;
    ``stagger`` shifts odd rows by half a cell (running bond / fish-scale layouts).
    """
    nx = int(np.ceil(extent[0] / cell)) + 2
    ny = int(np.ceil(extent[1] / cell)) + 2
    cols, rows = np.meshgrid(np.arange(nx) - 1, np.arange(ny) - 1)
    shift = 0.5 * (rows % 2) if stagger else 0.0
    pts = np.stack([(cols + 0.5 + shift) * cell, (rows + 0.5) * cell], -1).reshape(-1, 2)
    pts = pts + rng.uniform(-0.5, 0.5, size=pts.shape) * jitter * cell
    keep = rng.uniform(size=len(pts)) < presence
    return pts[keep].astype(np.float32)


def noisy_background(rng: np.random.Generator, h: int, w: int, color: np.ndarray,
                     amp: float, freq: float, octaves: int = 4) -> np.ndarray:
    """A colour plus fBm luminance/chroma noise. Shape: (H, W, 3) float32."""
    x, y, extent = coords(h, w)
    bg = np.broadcast_to(color.astype(np.float32), (h, w, 3)).copy()
    if amp > 0:
        lum = fbm(rng, x, y, freq, extent, octaves)
        tint = rng.normal(0.0, 0.3, 3).astype(np.float32) + 1.0
        bg += amp * lum[..., None] * tint
    return bg


def lighting(rng: np.random.Generator, image: np.ndarray, strength: float) -> np.ndarray:
    """Multiply by a linear illumination ramp in a random direction, +-``strength``."""
    h, w = image.shape[:2]
    x, y, extent = coords(h, w)
    theta = rng.uniform(0, 2 * np.pi)
    ramp = (x - extent[0] / 2) * np.cos(theta) + (y - extent[1] / 2) * np.sin(theta)
    ramp = ramp / (0.5 * np.hypot(*extent))  # in [-1, 1]
    return image * (1.0 + strength * ramp)[..., None]


def sensor_noise(rng: np.random.Generator, image: np.ndarray, sigma: float) -> np.ndarray:
    """Per-pixel noise of std ``sigma`` (the only resolution-dependent draw; keep it last).

    Uniform rather than Gaussian: same std, a third of the cost.
    """
    if sigma <= 0:
        return image
    u = rng.random(size=image.shape, dtype=np.float32)
    return image + (u - 0.5) * np.float32(sigma * np.sqrt(12.0))


def inner_fields(rng: np.random.Generator, h: int, w: int, noise_freq: float,
                 speckle_freq: float | None = None) -> dict:
    """Global fields textons sample for inner texture: ``noise`` fBm and ``speckle`` dots."""
    x, y, extent = coords(h, w)
    fields = {"noise": fbm(rng, x, y, noise_freq, extent, octaves=3)}
    if speckle_freq is not None:
        n = fbm(rng, x, y, speckle_freq, extent, octaves=2)
        fields["speckle"] = np.clip((n - 0.25) * 6.0, 0.0, 1.0) - 0.2
    return fields


def uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def pick_colors(rng: np.random.Generator, pal: np.ndarray, spread: float, k: int) -> np.ndarray:
    """``k`` colours: a random palette entry each, plus Gaussian variation. Shape: (k, 3)."""
    base = pal[rng.integers(0, len(pal), size=k)] if k else np.zeros((0, 3))
    return np.clip(base + rng.normal(0.0, spread, (k, 3)), 0.0, 1.0).astype(np.float32)
