"""Random affine transforms applied alike to images (kornia) and to textons (4.3.5.2).

A transform is x -> A x + t in the normalized coordinates of :mod:`neuraltex.coords`.
:func:`pixel_matrix` turns it into the (B, 2, 3) pixel matrix that
``kornia.geometry.transform.warp_affine`` expects (pixel j has its centre at j there, and at
(j + 0.5) / S here), so warping an image and transforming its textons agree.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import kornia
import torch
from torch import Tensor


class Affine(NamedTuple):
    A: Tensor  # (B, 2, 2)
    t: Tensor  # (B, 2)


def random_affine(batch: int, canvas: tuple[float, float], *, max_rotate: float = 45.0,
                  scale: tuple[float, float] = (0.8, 1.25), max_shift: float = 0.2,
                  generator: torch.Generator | None = None) -> Affine:
    """Rotation (degrees, uniform), isotropic log-uniform scale about the canvas centre, then a
    shift of up to ``max_shift`` x canvas size."""
    def uniform(lo: float, hi: float) -> Tensor:
        return lo + (hi - lo) * torch.rand(batch, generator=generator)

    angle = torch.deg2rad(uniform(-max_rotate, max_rotate))
    s = torch.exp(uniform(math.log(scale[0]), math.log(scale[1])))
    c, n = torch.cos(angle) * s, torch.sin(angle) * s
    A = torch.stack([torch.stack([c, n], -1), torch.stack([-n, c], -1)], -2)  # CCW on screen
    centre = torch.tensor(canvas) / 2
    shift = (torch.rand(batch, 2, generator=generator) * 2 - 1) * max_shift * torch.tensor(canvas)
    t = centre - (A @ centre) + shift
    return Affine(A, t)


def pixel_matrix(T: Affine, height: int, width: int) -> Tensor:
    """The kornia pixel-space matrix (B, 2, 3) of a normalized-space transform."""
    S = float(min(height, width))
    ones = torch.ones(2, dtype=T.A.dtype, device=T.A.device)
    b = 0.5 * (T.A @ ones - ones) + S * T.t  # x'_k = A x_k + b with x_k = S x_n - 0.5
    return torch.cat([T.A, b.unsqueeze(-1)], dim=-1)


def warp_images(images: Tensor, T: Affine, mode: str = "bilinear") -> tuple[Tensor, Tensor]:
    """Warp (B, C, H, W) images by T; returns (warped, valid) with valid (B, 1, H, W) = 1 where
    the warped pixel came from inside the source image."""
    H, W = images.shape[-2:]
    M = pixel_matrix(T, H, W).to(images)
    warped = kornia.geometry.transform.warp_affine(images, M, (H, W), mode=mode,
                                                   padding_mode="zeros", align_corners=True)
    ones = torch.ones_like(images[:, :1])
    valid = kornia.geometry.transform.warp_affine(ones, M, (H, W), mode="nearest",
                                                  padding_mode="zeros", align_corners=True)
    return warped, valid
