"""D and D_p: the image and patch discriminators (seed 003, 7.7.1).

D is StyleGAN2's residual discriminator (Karras et al. 2020; rosinality/stylegan2-pytorch
``model.py``: equalised learning rate, [1, 3, 3, 1] blur before every stride-2 conv, scaled leaky
ReLU) without the minibatch-std layer, as in the paper. To accept any input size >= 4 (not only
the training size), a block only downsamples while both sides are >= 8, and the features are
adaptively average-pooled to 4x4 before the final layers.

D_p is a 4-layer patch discriminator (pix2pix PatchGAN layout, no normalisation so that R1 stays
per-sample) that sees a real reference crop concatenated channel-wise with a real or fake crop
of the same size: it judges whether the second crop looks like the same texture as the first.
:func:`random_crops` takes 8 random crops per image.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn


@dataclass
class DiscriminatorConfig:
    in_channels: int = 3
    channels: tuple[int, ...] = (256, 512, 512, 512, 512, 512)  # StyleGAN2 config-f at 128^2

    @classmethod
    def preset(cls, name: str) -> DiscriminatorConfig:
        presets = {
            "tiny": cls(channels=(16, 32, 48, 48)),
            "small": cls(channels=(32, 64, 128, 128, 128)),
            "paper": cls(),
        }
        return presets[name]


@dataclass
class PatchDiscriminatorConfig:
    in_channels: int = 3  # per crop; the network sees 2 * in_channels
    base_channels: int = 64
    num_layers: int = 4
    crop_size: int = 32
    num_crops: int = 8

    @classmethod
    def preset(cls, name: str) -> PatchDiscriminatorConfig:
        presets = {
            "tiny": cls(base_channels=8, crop_size=16),
            "small": cls(base_channels=32, crop_size=32),
            "paper": cls(),
        }
        return presets[name]


# ----------------------------------------------------------------------------- StyleGAN2 layers


class EqualConv2d(nn.Module):
    """Conv with equalised learning rate: weights ~ N(0, 1), scaled by 1/sqrt(fan_in) when run."""

    def __init__(self, cin: int, cout: int, kernel: int, stride: int = 1, padding: int = 0,
                 bias: bool = True) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.randn(cout, cin, kernel, kernel))
        self.bias = nn.Parameter(torch.zeros(cout)) if bias else None
        self.scale, self.stride, self.padding = 1 / math.sqrt(cin * kernel**2), stride, padding

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.conv2d(x, self.weight * self.scale, self.bias, self.stride, self.padding)


class EqualLinear(nn.Module):
    def __init__(self, cin: int, cout: int) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.randn(cout, cin))
        self.bias = nn.Parameter(torch.zeros(cout))
        self.scale = 1 / math.sqrt(cin)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.linear(x, self.weight * self.scale, self.bias)


def scaled_lrelu(x: torch.Tensor) -> torch.Tensor:
    return F.leaky_relu(x, 0.2) * math.sqrt(2)  # StyleGAN2's fused_leaky_relu gain


class Blur(nn.Module):
    """Depthwise [1, 3, 3, 1] low-pass filter with explicit padding (anti-aliased downsampling)."""

    def __init__(self, pad: tuple[int, int]) -> None:
        super().__init__()
        k = torch.tensor([1.0, 3.0, 3.0, 1.0])
        k = k[:, None] * k[None, :]
        self.register_buffer("kernel", (k / k.sum())[None, None], persistent=False)  # (1, 1, 4, 4)
        self.pad = pad

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        c = x.shape[1]
        x = F.pad(x, (self.pad[0], self.pad[1], self.pad[0], self.pad[1]))
        return F.conv2d(x, self.kernel.expand(c, 1, 4, 4), groups=c)


class ConvLayer(nn.Module):
    """Equalised conv (+ blur and stride 2 when downsampling) (+ scaled leaky ReLU)."""

    def __init__(self, cin: int, cout: int, kernel: int, down: bool = False,
                 activate: bool = True, bias: bool = True) -> None:
        super().__init__()
        p = (4 - 2) + (kernel - 1)  # rosinality: blur padding so that H -> H/2 exactly
        self.blur = Blur(((p + 1) // 2, p // 2)) if down else None
        self.conv = EqualConv2d(cin, cout, kernel, stride=2 if down else 1,
                                padding=0 if down else kernel // 2, bias=bias and not activate)
        self.act_bias = nn.Parameter(torch.zeros(cout)) if activate and bias else None

    def forward(self, x: torch.Tensor, down: bool = True) -> torch.Tensor:
        if self.blur is None:
            x = self.conv(x)
        elif down:
            x = self.conv(self.blur(x))  # (B, cout, H/2, W/2)
        else:  # a downsampling layer on an input already at 4x4: same weights, stride 1
            x = F.conv2d(x, self.conv.weight * self.conv.scale, self.conv.bias, 1,
                         self.conv.weight.shape[-1] // 2)
        if self.act_bias is not None:
            x = scaled_lrelu(x + self.act_bias[None, :, None, None])
        return x


class DResBlock(nn.Module):
    def __init__(self, cin: int, cout: int) -> None:
        super().__init__()
        self.conv1 = ConvLayer(cin, cin, 3)
        self.conv2 = ConvLayer(cin, cout, 3, down=True)
        self.skip = ConvLayer(cin, cout, 1, down=True, activate=False, bias=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        down = min(x.shape[-2:]) >= 8  # keep >= 4x4 so any input size >= 4 works
        out = self.conv2(self.conv1(x), down)
        return (out + self.skip(x, down)) / math.sqrt(2)  # (B, cout, H/2, W/2)


class ImageDiscriminator(nn.Module):
    """D: image (B, 3, H, W), H, W >= 4 -> realness logits (B, 1)."""

    def __init__(self, in_channels: int = 3,
                 channels: tuple[int, ...] = (256, 512, 512, 512, 512, 512)) -> None:
        super().__init__()
        self.from_rgb = ConvLayer(in_channels, channels[0], 1)
        self.blocks = nn.Sequential(
            *[DResBlock(a, b) for a, b in zip(channels[:-1], channels[1:], strict=True)]
        )
        c = channels[-1]
        self.final_conv = ConvLayer(c, c, 3)  # no minibatch-std channel (paper, 7.7.1)
        self.final_linear = nn.Sequential(EqualLinear(c * 16, c), nn.LeakyReLU(0.2),
                                          EqualLinear(c, 1))

    @classmethod
    def from_config(cls, cfg: DiscriminatorConfig) -> ImageDiscriminator:
        return cls(**vars(cfg))  # the config's fields are the constructor's arguments

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        x = self.blocks(self.from_rgb(image))  # (B, C, h, w), h, w >= 4
        x = self.final_conv(F.adaptive_avg_pool2d(x, 4))  # (B, C, 4, 4)
        return self.final_linear(x.flatten(1))  # (B, 1)


# ----------------------------------------------------------------------------- patch D


class PatchDiscriminator(nn.Module):
    """D_p: (reference crop, crop), each (B, 3, s, s) -> patch logits (B, 1, h, w).

    ``num_layers`` 4x4 convs (the first ones stride 2, the last stride 1, widths doubling up to
    8x base) each followed by LeakyReLU(0.2), then a 3x3 conv to one logit map. Crops must be
    at least 2**num_layers pixels wide (16 for 4 layers) for a non-empty output.
    """

    def __init__(self, in_channels: int = 3, base_channels: int = 64, num_layers: int = 4,
                 crop_size: int = 32, num_crops: int = 8) -> None:
        super().__init__()
        self.crop_size, self.num_crops = crop_size, num_crops  # what the trainer feeds it
        layers: list[nn.Module] = []
        cin = 2 * in_channels  # reference and candidate, channel-wise
        for i in range(num_layers):
            cout = base_channels * min(2**i, 8)
            stride = 2 if i < num_layers - 1 else 1
            layers += [nn.Conv2d(cin, cout, 4, stride, 1), nn.LeakyReLU(0.2)]
            cin = cout
        layers.append(nn.Conv2d(cin, 1, 3, 1, 1))  # 3x3 keeps 16^2 crops valid
        self.net = nn.Sequential(*layers)

    @classmethod
    def from_config(cls, cfg: PatchDiscriminatorConfig) -> PatchDiscriminator:
        return cls(**vars(cfg))  # the config's fields are the constructor's arguments

    def forward(self, reference: torch.Tensor, crop: torch.Tensor) -> torch.Tensor:
        if reference.shape != crop.shape:
            raise ValueError(f"crop shapes differ: {tuple(reference.shape)} {tuple(crop.shape)}")
        return self.net(torch.cat((reference, crop), dim=1))  # (B, 1, h, w)


def random_crops(images: torch.Tensor, size: int, num_crops: int = 8,
                 generator: torch.Generator | None = None) -> torch.Tensor:
    """``num_crops`` random square crops per image, grouped by image.

    Shape: (B, C, H, W) -> (B * num_crops, C, size, size); crop j of image b is row
    b * num_crops + j. Differentiable w.r.t. ``images`` (plain indexing).
    """
    b, c, h, w = images.shape
    if size > h or size > w:
        raise ValueError(f"crop size {size} larger than the image {h}x{w}")
    ys = torch.randint(0, h - size + 1, (b, num_crops), generator=generator)
    xs = torch.randint(0, w - size + 1, (b, num_crops), generator=generator)
    ar = torch.arange(size)
    rows = (ys[..., None] + ar).to(images.device)  # (B, N, s)
    cols = (xs[..., None] + ar).to(images.device)  # (B, N, s)
    bidx = torch.arange(b, device=images.device)[:, None, None, None]
    crops = images.permute(0, 2, 3, 1)[bidx, rows[..., :, None], cols[..., None, :]]  # (B,N,s,s,C)
    return crops.permute(0, 1, 4, 2, 3).reshape(b * num_crops, c, size, size)
