"""Colour palettes: random, well-spread base colours and per-texton variations."""

from __future__ import annotations

import numpy as np
from skimage.color import hsv2rgb


def hsv_to_rgb(hsv: np.ndarray) -> np.ndarray:
    """HSV -> RGB (skimage). Shape: (..., 3) -> (..., 3), all in [0, 1]."""
    return hsv2rgb(np.atleast_2d(hsv), channel_axis=-1).reshape(hsv.shape)


def palette(rng: np.random.Generator, n: int, value: tuple[float, float] = (0.35, 0.95),
            saturation: tuple[float, float] = (0.3, 0.9)) -> np.ndarray:
    """``n`` colours with hues spread around the wheel from a random start. Shape: (n, 3)."""
    hue = (rng.uniform() + np.arange(n) / n + rng.uniform(-0.08, 0.08, n)) % 1.0
    hsv = np.stack([hue, rng.uniform(*saturation, n), rng.uniform(*value, n)], -1)
    return hsv_to_rgb(hsv).astype(np.float32)


def background_color(rng: np.random.Generator, dark: bool | None = None) -> np.ndarray:
    """A background colour that is clearly darker or lighter than mid-grey. Shape: (3,)."""
    if dark is None:
        dark = bool(rng.uniform() < 0.5)
    value = rng.uniform(0.05, 0.25) if dark else rng.uniform(0.85, 0.98)
    hsv = np.array([rng.uniform(), rng.uniform(0.0, 0.4), value])
    return hsv_to_rgb(hsv).astype(np.float32)


def near(rng: np.random.Generator, color: np.ndarray, spread: float, n: int = 1) -> np.ndarray:
    """``n`` colours around ``color`` (Gaussian, clipped). Shape: (3,) -> (n, 3)."""
    out = color[None, :] + rng.normal(0.0, spread, size=(n, 3))
    return np.clip(out, 0.0, 1.0).astype(np.float32)
