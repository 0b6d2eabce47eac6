"""E_FC: the shallow fully-convolutional image encoder (seed 003, 4.3.2.2 and Table 7.1).

Residual down-blocks (each halves the resolution) feed two up-branches: an appearance branch
producing F_a and a direction branch producing V. All convolutions use reflection padding so the
network cannot read absolute position from zero-padded borders (appendix 7.7.1).

Paper sizes (Table 7.1): ResBlocks 3->64->128->256->512 (stride 16), then per branch
UpBlock(512, 256) -> UpBlock(256, 382) for F_a and UpBlock(512, 256) -> UpBlock(256, 2) for V,
so the native output stride is 4 (F_a is 32x32x382 for a 128x128 image). As in the paper the
maps are then upsampled bilinearly to the input size; ``upsample_output=False`` returns the
native stride-4 maps instead. Inputs whose sides are not multiples of 2**len(down_channels) are
reflection-padded internally and the outputs cropped back. BatchNorm (Table 7.1) needs more
than one value per channel in training mode, so train with batch * (H/16) * (W/16) > 1.

One small deviation from Table 7.1: the last UpBlock of each branch is a plain convolution
(no BatchNorm/LeakyReLU), so F_a and V are unconstrained signed maps; both are L2-normalised
per texton after pooling (eqs. 4.6-4.7) by the estimation layer.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from neuraltex.nn_utils import pad_to_multiple, resize


@dataclass
class EncoderConfig:
    in_channels: int = 3
    down_channels: tuple[int, ...] = (64, 128, 256, 512)
    up_channels: tuple[int, ...] = (256,)  # hidden up-blocks; one more up-block gives the output
    appearance_channels: int = 382  # C_a (paper: 382, so C_a + 2 = 384)
    upsample_output: bool = True

    @classmethod
    def preset(cls, name: str) -> EncoderConfig:
        presets = {
            "tiny": cls(down_channels=(16, 24, 32, 48), up_channels=(32,), appearance_channels=14),
            "small": cls(down_channels=(32, 64, 128, 192), up_channels=(128,),
                         appearance_channels=62),
            "paper": cls(),
        }
        return presets[name]


def conv3x3(cin: int, cout: int, stride: int = 1) -> nn.Sequential:
    return nn.Sequential(nn.ReflectionPad2d(1), nn.Conv2d(cin, cout, 3, stride=stride))


class ResDownBlock(nn.Module):
    """ResBlock(cin, cout) of Table 7.1: residual block that halves the resolution."""

    def __init__(self, cin: int, cout: int) -> None:
        super().__init__()
        self.main = nn.Sequential(
            conv3x3(cin, cout), nn.BatchNorm2d(cout), nn.LeakyReLU(0.2),
            conv3x3(cout, cout, stride=2), nn.BatchNorm2d(cout),
        )
        self.skip = nn.Sequential(nn.AvgPool2d(2), nn.Conv2d(cin, cout, 1))
        self.act = nn.LeakyReLU(0.2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.act(self.main(x) + self.skip(x))  # (B, cout, H/2, W/2)


class UpBlock(nn.Module):
    """UpBlock(cin, cout) of Table 7.1: Upsample(2) -> Conv -> BatchNorm -> LeakyReLU(0.2)."""

    def __init__(self, cin: int, cout: int, last: bool = False) -> None:
        super().__init__()
        layers: list[nn.Module] = [nn.Upsample(scale_factor=2, mode="nearest"), conv3x3(cin, cout)]
        if not last:
            layers += [nn.BatchNorm2d(cout), nn.LeakyReLU(0.2)]
        self.block = nn.Sequential(*layers)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.block(x)  # (B, cout, 2H, 2W)


def _branch(cin: int, hidden: tuple[int, ...], cout: int) -> nn.Sequential:
    chans = (cin, *hidden)
    blocks = [UpBlock(a, b) for a, b in zip(chans[:-1], chans[1:], strict=True)]
    return nn.Sequential(*blocks, UpBlock(chans[-1], cout, last=True))


class FCEncoder(nn.Module):
    """E_FC: image -> (appearance map F_a, direction map V).

    Shape: image (B, C_in, H, W) -> F_a (B, C_a, H, W), V (B, 2, H, W)
    (or at H/stride, W/stride with ``upsample_output=False``; see :attr:`stride`).
    """

    def __init__(
        self,
        in_channels: int = 3,
        down_channels: tuple[int, ...] = (64, 128, 256, 512),
        up_channels: tuple[int, ...] = (256,),
        appearance_channels: int = 382,
        upsample_output: bool = True,
    ) -> None:
        super().__init__()
        if len(up_channels) + 1 > len(down_channels):
            raise ValueError("more up-blocks than down-blocks")
        chans = (in_channels, *down_channels)
        self.down = nn.Sequential(
            *[ResDownBlock(a, b) for a, b in zip(chans[:-1], chans[1:], strict=True)]
        )
        self.appearance = _branch(down_channels[-1], up_channels, appearance_channels)
        self.direction = _branch(down_channels[-1], up_channels, 2)
        self.pad_multiple = 2 ** len(down_channels)
        self.stride = 2 ** (len(down_channels) - len(up_channels) - 1)  # native output stride
        self.appearance_channels = appearance_channels
        self.upsample_output = upsample_output

    @classmethod
    def from_config(cls, cfg: EncoderConfig) -> FCEncoder:
        return cls(**vars(cfg))  # the config's fields are the constructor's arguments

    def forward(self, image: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h, w = image.shape[-2:]
        x = pad_to_multiple(image, self.pad_multiple)  # (B, C_in, H', W')
        x_pad_hw = x.shape[-2:]
        x = self.down(x)  # (B, C_down, H'/16, W'/16)
        f_a = self.appearance(x)  # (B, C_a, H'/s, W'/s)
        v = self.direction(x)  # (B, 2, H'/s, W'/s)
        if self.upsample_output:  # upsample the padded map, then crop: pixel-exact alignment
            f_a = resize(f_a, tuple(x_pad_hw))[..., :h, :w]  # (B, C_a, H, W)
            v = resize(v, tuple(x_pad_hw))[..., :h, :w]  # (B, 2, H, W)
            return f_a, v
        hs, ws = -(-h // self.stride), -(-w // self.stride)
        return f_a[..., :hs, :ws], v[..., :hs, :ws]  # (B, C, ceil(H/s), ceil(W/s))
