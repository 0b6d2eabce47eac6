"""Augmentations (seed 003, section 4.3.7): random affine and colour-histogram matching.

The affine warp never samples outside the source: when rotation, shear or shrinking
would show the image border, it zooms in until the output fits. So no padding is
invented and the instance mask (warped with nearest neighbour) stays exact; textons
pushed out of the frame disappear and the ids are made consecutive again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from neuraltex.data.generator import relabel


def affine_matrix(rng: np.random.Generator, max_rotate: float, scale: tuple[float, float],
                  max_shear: float, flip: bool) -> np.ndarray:
    """A random 2x2 map from output offsets to input offsets, (row, col) order."""
    theta = rng.uniform(-max_rotate, max_rotate)
    c, s = math.cos(theta), math.sin(theta)
    rot = np.array([[c, -s], [s, c]])
    shear = np.array([[1.0, rng.uniform(-max_shear, max_shear)], [0.0, 1.0]])
    zoom = np.diag(1.0 / rng.uniform(*scale, size=2))  # output px -> input px
    mirror = np.diag([1.0, -1.0 if (flip and rng.uniform() < 0.5) else 1.0])
    return rot @ shear @ zoom @ mirror


def random_affine(rng: np.random.Generator, image: np.ndarray, mask: np.ndarray | None = None,
                  max_rotate: float = math.pi, scale: tuple[float, float] = (0.8, 1.25),
                  max_shear: float = 0.15, flip: bool = True):
    """Warp ``image`` (H, W, 3) bilinearly and ``mask`` (H, W) by nearest neighbour.

    Returns (image (H, W, 3) float32, mask (H, W) int32 or None). Output size = input size.
    """
    if image.ndim != 3:
        raise ValueError(f"image must be (H, W, C), got {image.shape}")
    h, w = image.shape[:2]
    a = affine_matrix(rng, max_rotate, scale, max_shear, flip)
    half = np.array([(h - 1) / 2.0, (w - 1) / 2.0])
    corners = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]]) * half  # (4, 2)
    reach = np.abs(corners @ a.T).max(0)  # (2,) how far the footprint reaches
    fit = max(1.0, float((reach / np.maximum(half, 1e-9)).max()))
    a = a / fit  # zoom in until the footprint fits the source
    slack = np.maximum(half - np.abs(corners @ a.T).max(0), 0.0)
    centre = half + rng.uniform(-1.0, 1.0, 2) * slack
    offset = centre - a @ half
    rows, cols = np.arange(h, dtype=np.float32), np.arange(w, dtype=np.float32)
    src_r = a[0, 0] * rows[:, None] + a[0, 1] * cols[None, :] + offset[0]  # (H, W)
    src_c = a[1, 0] * rows[:, None] + a[1, 1] * cols[None, :] + offset[1]
    out = _bilinear(image, src_r, src_c)
    if mask is None:
        return out, None
    r = np.clip(np.rint(src_r).astype(np.int64), 0, h - 1)
    c = np.clip(np.rint(src_c).astype(np.int64), 0, w - 1)
    return out, relabel(mask[r, c])


def _bilinear(image: np.ndarray, r: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Sample (H, W, C) at fractional (row, col) maps (h, w), clamping at the border."""
    h, w, ch = image.shape
    shape = r.shape
    r = np.clip(r, 0, h - 1).astype(np.float32).ravel()
    c = np.clip(c, 0, w - 1).astype(np.float32).ravel()
    r0 = np.minimum(r.astype(np.int64), max(h - 2, 0))
    c0 = np.minimum(c.astype(np.int64), max(w - 2, 0))
    fr, fc = r - r0.astype(np.float32), c - c0.astype(np.float32)  # (h*w,) float32
    i00 = r0 * w + c0  # flat index of the top-left neighbour
    i01, i10 = i00 + (1 if w > 1 else 0), i00 + (w if h > 1 else 0)
    i11 = i10 + (1 if w > 1 else 0)
    # Work on contiguous colour planes: numpy is slow on a short trailing axis.
    planes = np.ascontiguousarray(image.transpose(2, 0, 1)).reshape(ch, -1)  # (C, H*W)
    out = np.empty((ch, r.size), np.float32)
    for k in range(ch):
        p = planes[k]
        top = p.take(i00) + (p.take(i01) - p.take(i00)) * fc
        bottom = p.take(i10) + (p.take(i11) - p.take(i10)) * fc
        out[k] = top + (bottom - top) * fr
    return np.ascontiguousarray(out.T).reshape(*shape, ch)


def match_histograms(image: np.ndarray, reference: np.ndarray, knots: int = 17,
                     max_slope: float = 3.0) -> np.ndarray:
    """Per-channel histogram matching of ``image`` onto ``reference``, regularized.

    Exact matching of a flat-coloured texture (one value plus sensor noise) spreads the
    noise over the reference's whole range. Here the transfer curve is piecewise linear
    through ``knots`` matched quantiles and its slope is capped at ``max_slope``, so
    noise is amplified at most that much. Shape: (H, W, C), (h, w, C) -> (H, W, C).
    """
    if image.ndim != 3 or reference.ndim != 3 or image.shape[2] != reference.shape[2]:
        raise ValueError(f"expected (H, W, C) images with equal C, got {image.shape}, "
                         f"{reference.shape}")
    q = np.linspace(0.02, 0.98, knots)
    # Quantiles from at most ~4096 pixels each: plenty for 17 knots, and 4x cheaper.
    src = np.quantile(_subsample(image), q, axis=0)  # (knots, C)
    ref = np.quantile(_subsample(reference), q, axis=0)
    planes = np.ascontiguousarray(image.transpose(2, 0, 1))  # (C, H, W)
    out = np.empty(planes.shape, np.float32)
    for ch in range(image.shape[2]):
        xs, ys = src[:, ch], ref[:, ch]
        dy = np.minimum(np.diff(ys), max_slope * np.diff(xs))  # (knots - 1,)
        ys = np.concatenate([[0.0], np.cumsum(dy)])
        ys += ref[knots // 2, ch] - ys[knots // 2]  # keep the medians matched
        # Beyond the outer knots continue with slope 1.
        xs = np.concatenate([[xs[0] - 1.0], xs, [xs[-1] + 1.0]])
        ys = np.concatenate([[ys[0] - 1.0], ys, [ys[-1] + 1.0]])
        out[ch] = np.interp(planes[ch], xs, ys)
    return np.ascontiguousarray(np.clip(out, 0.0, 1.0).transpose(1, 2, 0))


def _subsample(image: np.ndarray, limit: int = 4096) -> np.ndarray:
    flat = image.reshape(-1, image.shape[2])
    return flat[:: max(1, len(flat) // limit)]


@dataclass
class Augment:
    """Random affine (probability ``affine_p``) then histogram matching (``hist_p``)."""

    affine_p: float = 1.0
    hist_p: float = 0.5
    max_rotate: float = math.pi
    scale: tuple[float, float] = (0.8, 1.25)
    max_shear: float = 0.15
    flip: bool = True

    def __call__(self, rng: np.random.Generator, image: np.ndarray,
                 mask: np.ndarray | None = None, reference: np.ndarray | None = None):
        """Returns (image, mask); ``reference`` is used only when histogram matching fires."""
        if rng.uniform() < self.affine_p:
            image, mask = random_affine(rng, image, mask, self.max_rotate, self.scale,
                                        self.max_shear, self.flip)
        if reference is not None and rng.uniform() < self.hist_p:
            image = match_histograms(image, reference)
        return image, mask
