"""Backbones for the segmentation head E_s: multi-scale features at strides 4, 8, 16, 32.

:class:`SmallBackbone` is a small residual conv net for tiny/small configs (GroupNorm, so it
works on 1x1 maps at batch 1); :class:`ResNet50Backbone` is torchvision's ResNet-50 as in the
paper (7.7.1), randomly initialised unless a local state_dict file is given; it never downloads.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn


def group_norm(ch: int) -> nn.GroupNorm:
    return nn.GroupNorm(math.gcd(32, max(ch // 4, 1)), ch)  # >= 4 channels per group


class BasicDownBlock(nn.Module):
    """Residual basic block that halves the resolution (GroupNorm: works for 1x1 maps, batch 1)."""

    def __init__(self, cin: int, cout: int) -> None:
        super().__init__()
        self.main = nn.Sequential(
            nn.Conv2d(cin, cout, 3, 2, 1, bias=False), group_norm(cout), nn.ReLU(),
            nn.Conv2d(cout, cout, 3, 1, 1, bias=False), group_norm(cout),
        )
        self.skip = nn.Sequential(nn.Conv2d(cin, cout, 1, 2, bias=False), group_norm(cout))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.relu(self.main(x) + self.skip(x))


class SmallBackbone(nn.Module):
    """A small conv net with ResNet's strides: features at strides 4, 8, 16, 32."""

    def __init__(self, in_channels: int, channels: tuple[int, ...]) -> None:
        super().__init__()
        if len(channels) != 4:
            raise ValueError("SmallBackbone needs 4 stage widths")
        c0 = channels[0]
        self.stem = nn.Sequential(
            nn.Conv2d(in_channels, c0, 3, 2, 1, bias=False), group_norm(c0), nn.ReLU(),
            BasicDownBlock(c0, c0),
        )
        pairs = zip(channels[:-1], channels[1:], strict=True)
        self.stages = nn.ModuleList(BasicDownBlock(a, b) for a, b in pairs)
        self.out_channels = tuple(channels)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        feats = [self.stem(x)]  # (B, c0, H/4, W/4)
        for stage in self.stages:
            feats.append(stage(feats[-1]))  # (B, c_i, H/2^(i+2), W/2^(i+2))
        return feats


class ResNet50Backbone(nn.Module):
    """torchvision ResNet-50 (res2..res5). Random init unless a local state_dict file is given."""

    def __init__(self, in_channels: int = 3, weights_path: str | None = None) -> None:
        super().__init__()
        import torchvision  # only the paper preset needs it; keeps CLI start-up short

        net = torchvision.models.resnet50(weights=None)
        if weights_path is not None:
            state = torch.load(weights_path, map_location="cpu", weights_only=True)
            net.load_state_dict(state, strict=False)  # the fc head is unused
        if in_channels != 3:
            net.conv1 = nn.Conv2d(in_channels, 64, 7, 2, 3, bias=False)
        self.stem = nn.Sequential(net.conv1, net.bn1, net.relu, net.maxpool)
        self.stages = nn.ModuleList([net.layer1, net.layer2, net.layer3, net.layer4])
        self.out_channels = (256, 512, 1024, 2048)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        x = self.stem(x)  # (B, 64, H/4, W/4)
        feats = []
        for stage in self.stages:
            x = stage(x)
            feats.append(x)  # strides 4, 8, 16, 32
        return feats
