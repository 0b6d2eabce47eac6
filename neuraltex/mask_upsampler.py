"""A light learned upsampler for E_s's mask features: stride 4 -> stride 2 or 1, guided by the
image, so mask logits keep the edges of small elements (``model.mask_stride``).

E_s predicts masks as query embeddings . per-pixel mask features; the FPN gives those features
at stride 4. This module upsamples them bilinearly and adds a correction computed from the
upsampled features and a shallow encoding of the image at the target stride. The correction's
last conv starts at zero, so a fresh upsampler is exactly bilinear upsampling (the logits are
linear in the features): a trained stride-4 E_s keeps its masks when the upsampler is added,
and training only has to learn the edges.

Shape: features (B, C, h, w) at stride 4 of the padded image (B, C_in, 4h, 4w)
-> (B, C, 4h / s, 4w / s).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from neuraltex.backbones import group_norm


class MaskUpsampler(nn.Module):
    def __init__(self, in_channels: int, dim: int, stride: int) -> None:
        super().__init__()
        if stride not in (1, 2):
            raise ValueError(f"mask upsampler stride must be 1 or 2, got {stride}")
        self.stride = stride
        self.image = nn.Sequential(  # the image at the target stride, dim channels
            nn.Conv2d(in_channels, dim, 3, stride, 1, bias=False), group_norm(dim), nn.ReLU(),
            nn.Conv2d(dim, dim, 3, 1, 1))
        self.fuse = nn.Conv2d(dim, dim, 3, 1, 1)
        nn.init.zeros_(self.fuse.weight)  # starts as plain bilinear upsampling
        nn.init.zeros_(self.fuse.bias)

    def forward(self, features: torch.Tensor, image: torch.Tensor) -> torch.Tensor:
        size = (image.shape[-2] // self.stride, image.shape[-1] // self.stride)
        up = F.interpolate(features, size=size, mode="bilinear", align_corners=False)
        return up + self.fuse(F.relu(up + self.image(image)))  # (B, C, H/s, W/s)
