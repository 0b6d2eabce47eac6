"""Palette transfer between texture files: one tuned texture's structure and detail in the
colours of another (seed 003, 4.4.2, for texture files).

A tuned decoder renders only what it was tuned on: given another texture's layout, the
appearance texture's G paints smudges, and blending two decoders' weights paints noise (both
seen in earlier galleries). So the structure texture file is rendered as tuned — its own
decoder, its own textons, sharp — and its textons are recoloured in the picture: texton k's
segment takes the colour of the appearance texture's texton at the same rank of luminance,
ranks weighted by area (histogram matching of the two textures' texton colours),

    I'(x) = I(x) + c_B(q_k) - c_A,k   for x in segment k,   q_k = area share of A's textons
                                                            darker than k (+ half of k's)

where c_A,k is the segment's mean colour in A's reconstruction I and c_B(q) the colour at
area quantile q of B's textons (linear between them); the shift is feathered across segment
borders. Dark spots stay the dark ones, the ground the ground; the detail is A's own.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import Tensor

from neuraltex.nn_utils import blur, labels_at

LUMA = (0.299, 0.587, 0.114)  # ITU-R BT.601 weights of R, G, B
FEATHER = 1.0  # std (px) of the blend of two segments' colour shifts at their border


def texton_colours(picture: Tensor, labels: np.ndarray,
                   count: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Mean colour (K, 3) and area (K,) in pixels of each texton's segment in a picture
    (3, H, W); labels (h, w) texton of each pixel at the fit's size (resampled). With
    ``count``, K = count: textons without a pixel get colour 0 and area 0."""
    from neuraltex.fit import segment_means

    labels = labels_at(labels, tuple(picture.shape[-2:]))
    K = max(int(labels.max()) + 1, count or 0)
    colours = np.zeros((K, 3))
    means = segment_means(picture.detach().double().cpu(), labels)[0].numpy()
    colours[:len(means)] = means
    area = np.bincount(labels.ravel(), minlength=K).astype(np.float64)
    return colours, area


def quantiles(colours: np.ndarray, area: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(order by luminance (K,), area quantile of each texton's middle (K,) in that order)."""
    order = np.argsort(colours @ np.asarray(LUMA), kind="stable")
    a = area[order] / max(area.sum(), 1e-12)
    return order, np.cumsum(a) - a / 2


def rank_colours(colours_a: np.ndarray, area_a: np.ndarray, colours_b: np.ndarray,
                 area_b: np.ndarray) -> np.ndarray:
    """(K_a, 3): for each texton of A, the colour of B's textons at its area-weighted
    luminance quantile (:func:`quantiles`), linear between B's textons."""
    order_a, q_a = quantiles(colours_a, area_a)
    order_b, q_b = quantiles(colours_b, area_b)
    out = np.empty_like(colours_a)
    for c in range(3):
        out[order_a, c] = np.interp(q_a, q_b, colours_b[order_b, c])
    return out


def recolour(picture: Tensor, labels: np.ndarray, colours: np.ndarray, target: np.ndarray,
             feather: float = FEATHER) -> Tensor:
    """A picture (3, H, W) with every texton's segment (labels (h, w), resampled) moved from
    its mean colour ``colours`` (K, 3) to ``target`` (K, 3): the shift of each pixel's
    segment, blurred by ``feather`` px across segment borders, added; the detail inside a
    segment (its shading, edges, the sprites) stays."""
    lab = torch.from_numpy(labels_at(labels, tuple(picture.shape[-2:])))
    shift = torch.from_numpy(target - colours).to(picture)[lab].permute(2, 0, 1)  # (3, H, W)
    shift = blur(shift, feather)
    return (picture + shift).clamp(0, 1)


def palette_blend(a: Tensor, labels_a: np.ndarray, b: Tensor, labels_b: np.ndarray,
                  t: Tensor | float) -> Tensor:
    """Interpolation between two texture files' reconstructions a, b (3, H, W; labels
    (h, w) of each): at t (a float, or (H, W) for a spatial ramp) each picture is recoloured
    t (resp. 1 - t) of the way toward the other's palette by luminance rank (so both show one
    palette), then the two are mixed, (1 - t) a_t + t b_t, with the variance the mix loses
    restored: for uncorrelated textures it falls to (1 - t)^2 s_a^2 + t^2 s_b^2 (a washed-out
    middle), and it is scaled around the mean back to (1 - t) s_a^2 + t s_b^2 per channel."""
    a_as_b = palette_transfer(a, labels_a, b, labels_b)
    b_as_a = palette_transfer(b, labels_b, a, labels_a)
    t = torch.as_tensor(t, dtype=a.dtype)
    a_t = torch.lerp(a, a_as_b, t)
    b_t = torch.lerp(b_as_a, b, t)
    mix = torch.lerp(a_t, b_t, t)
    var_a, var_b = a.var((1, 2))[:, None, None], b.var((1, 2))[:, None, None]  # (3, 1, 1)
    mean = torch.lerp(a_t.mean((1, 2), keepdim=True), b_t.mean((1, 2), keepdim=True), t)
    lost = (1 - t) ** 2 * var_a + t ** 2 * var_b
    want = (1 - t) * var_a + t * var_b
    gain = (want / lost.clamp_min(1e-8)).sqrt()
    return (mean + gain * (mix - mean)).clamp(0, 1)


def palette_transfer(a: Tensor, labels_a: np.ndarray, b: Tensor,
                     labels_b: np.ndarray) -> Tensor:
    """Picture a (3, H, W) recoloured texton by texton with picture b's texton colours of
    the same luminance rank (:func:`rank_colours`); labels (h, w) of each."""
    ca, na = texton_colours(a, labels_a)
    return recolour(a, labels_a, ca, rank_colours(ca, na, *texton_colours(b, labels_b)))
