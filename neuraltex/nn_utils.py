"""Small tensor helpers shared by the networks: padding to a stride, resizing, counting."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


def pad_to_multiple(x: torch.Tensor, multiple: int) -> torch.Tensor:
    """Pad ``x`` (B, C, H, W) on the bottom/right so H and W are multiples of ``multiple``.

    Reflection padding (no hard border the network could use as a position cue); replicate
    padding when the image is too small to reflect. Crop back with ``x[..., :H, :W]``.
    """
    h, w = x.shape[-2:]
    ph, pw = (-h) % multiple, (-w) % multiple
    if ph == 0 and pw == 0:
        return x
    mode = "reflect" if ph < h and pw < w else "replicate"
    return F.pad(x, (0, pw, 0, ph), mode=mode)


def resize(x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """Bilinear resize of (B, C, H, W) to ``size``; antialiased when shrinking."""
    if tuple(x.shape[-2:]) == tuple(size):
        return x
    shrink = size[0] < x.shape[-2] or size[1] < x.shape[-1]
    return F.interpolate(x, size=size, mode="bilinear", align_corners=False, antialias=shrink)


def shrink_short_side(x: torch.Tensor, short: int) -> torch.Tensor:
    """(B, C, H, W) downscaled (antialiased, never enlarged) so its short side is at most
    ``short``; the aspect ratio is kept."""
    H, W = x.shape[-2:]
    if min(H, W) <= short:
        return x
    s = short / min(H, W)
    return resize(x, (max(1, round(H * s)), max(1, round(W * s))))


def count_parameters(module: nn.Module, trainable_only: bool = True) -> int:
    """Number of (trainable) scalar parameters of ``module``."""
    return sum(p.numel() for p in module.parameters() if p.requires_grad or not trainable_only)
