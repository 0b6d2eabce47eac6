"""G: the SPADE generator that decodes splatted textons into an image (seed 003, 4.3.4, 7.7.1).

SPADE (Park et al. 2019, NVlabs/SPADE ``models/networks/normalization.py`` and
``architecture.py``) normalises activations without affine parameters and re-modulates them with
a per-pixel scale and shift predicted from a conditioning map; here that map is the splatted
feature grid F_s (B, C_a+2, H, W), resized to each level.

Following the paper, the generator's *input* is not SPADE's learned constant but the max-opacity
map F_max = max_i o_i (B, 1, H, W) downscaled by 2**(len(channels)-1) (1/4 of the output for
the paper), so any output size works. With ``concat_features=True`` (default) the downscaled F_s
is concatenated to that input: a CPU prototype only learned when the decoder saw the features
directly, not only through the modulation.

Paper sizes (7.7.1): blocks give H/4 x 384, H/2 x 192, H x 96 and H x 3, i.e. ``channels =
(384, 192, 96)`` and a last SPADE block to ``out_channels = 3``. The output goes through tanh,
so it is in [-1, 1] (``output_activation="sigmoid"`` gives [0, 1]). Any output size works: the
level sizes are ceil-halvings of the output size, and upsampling goes to the next exact size.
The parameter-free BatchNorm (SPADE's default) needs batch * (H/4) * (W/4) > 1 in training
mode; ``norm="instance"`` needs (H/4) * (W/4) > 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import torch
import torch.nn.functional as F
from torch import nn
from torch.nn.utils.parametrizations import spectral_norm

from neuraltex.nn_utils import resize


@dataclass
class GeneratorConfig:
    feature_channels: int = 384  # C_a + 2 (appearance + direction)
    channels: tuple[int, ...] = (384, 192, 96)  # one SPADE block per entry, then one to RGB
    out_channels: int = 3
    spade_hidden: int = 128
    spade_kernel: int = 3  # SPADE's "spade...3x3" kernel; 1 makes the modulation 9x cheaper
    norm: Literal["batch", "instance"] = "batch"
    use_spectral_norm: bool = True
    concat_features: bool = True
    output_activation: Literal["tanh", "sigmoid"] = "tanh"

    @classmethod
    def preset(cls, name: str) -> GeneratorConfig:
        presets = {
            "tiny": cls(feature_channels=16, channels=(32, 16, 8), spade_hidden=16),
            "small": cls(feature_channels=64, channels=(128, 64, 32), spade_hidden=64),
            "paper": cls(),
        }
        return presets[name]


class SPADE(nn.Module):
    """Spatially-adaptive normalisation: norm(x) * (1 + gamma(cond)) + beta(cond).

    Shape: x (B, C, h, w), cond (B, C_cond, H, W) (resized to h, w) -> (B, C, h, w).
    """

    def __init__(self, channels: int, cond_channels: int, hidden: int,
                 norm: Literal["batch", "instance"] = "batch", kernel: int = 3) -> None:
        super().__init__()
        if norm == "batch":
            self.norm: nn.Module = nn.BatchNorm2d(channels, affine=False)
        else:
            self.norm = nn.InstanceNorm2d(channels, affine=False)
        pad = kernel // 2
        self.shared = nn.Sequential(nn.Conv2d(cond_channels, hidden, kernel, padding=pad),
                                    nn.ReLU())
        self.gamma = nn.Conv2d(hidden, channels, kernel, padding=pad)
        self.beta = nn.Conv2d(hidden, channels, kernel, padding=pad)

    def forward(self, x: torch.Tensor, cond: torch.Tensor) -> torch.Tensor:
        actv = self.shared(resize(cond, tuple(x.shape[-2:])))  # (B, hidden, h, w)
        # gamma and beta as one convolution (same weights; ~2x faster than two on CPU)
        weight = torch.cat((self.gamma.weight, self.beta.weight))  # (2C, hidden, k, k)
        bias = torch.cat((self.gamma.bias, self.beta.bias))
        gamma, beta = F.conv2d(actv, weight, bias, padding=self.gamma.padding).chunk(2, dim=1)
        return self.norm(x) * (1 + gamma) + beta


class SPADEResBlock(nn.Module):
    """SPADE ResBlock: [SPADE, LReLU, conv] x 2 plus a (learned when cin != cout) shortcut."""

    def __init__(self, cin: int, cout: int, cond_channels: int, hidden: int,
                 norm: Literal["batch", "instance"] = "batch", use_spectral_norm: bool = True,
                 spade_kernel: int = 3) -> None:
        super().__init__()
        mid = min(cin, cout)
        sn = spectral_norm if use_spectral_norm else (lambda m: m)
        self.conv_0 = sn(nn.Conv2d(cin, mid, 3, padding=1))
        self.conv_1 = sn(nn.Conv2d(mid, cout, 3, padding=1))
        self.norm_0 = SPADE(cin, cond_channels, hidden, norm, spade_kernel)
        self.norm_1 = SPADE(mid, cond_channels, hidden, norm, spade_kernel)
        self.learned_shortcut = cin != cout
        if self.learned_shortcut:
            self.conv_s = sn(nn.Conv2d(cin, cout, 1, bias=False))
            self.norm_s = SPADE(cin, cond_channels, hidden, norm, spade_kernel)

    def forward(self, x: torch.Tensor, cond: torch.Tensor) -> torch.Tensor:
        xs = self.conv_s(self.norm_s(x, cond)) if self.learned_shortcut else x
        dx = self.conv_0(F.leaky_relu(self.norm_0(x, cond), 0.2))
        dx = self.conv_1(F.leaky_relu(self.norm_1(dx, cond), 0.2))
        return xs + dx  # (B, cout, h, w)


def level_sizes(size: tuple[int, int], n_levels: int) -> list[tuple[int, int]]:
    """Sizes from coarsest to finest; each is the ceil-half of the next, the last is ``size``."""
    sizes = [tuple(size)]
    for _ in range(n_levels - 1):
        h, w = sizes[0]
        sizes.insert(0, (-(-h // 2), -(-w // 2)))
    return sizes


class SPADEGenerator(nn.Module):
    """G: (F_s (B, C_a+2, H, W), F_max (B, 1, H, W)) -> image (B, 3, H, W) in [-1, 1] (tanh).

    One SPADE res-block per entry of ``channels`` plus one to ``out_channels``; block i < k runs
    at 1/2**(k-1-i) of the output size (k = len(channels)) and the last one at full size:
    H/4, H/2, H, H for the paper.
    """

    def __init__(
        self,
        feature_channels: int = 384,
        channels: tuple[int, ...] = (384, 192, 96),
        out_channels: int = 3,
        spade_hidden: int = 128,
        spade_kernel: int = 3,
        norm: Literal["batch", "instance"] = "batch",
        use_spectral_norm: bool = True,
        concat_features: bool = True,
        output_activation: Literal["tanh", "sigmoid"] = "tanh",
    ) -> None:
        super().__init__()
        self.concat_features = concat_features
        in_ch = 1 + (feature_channels if concat_features else 0)
        self.fc = nn.Conv2d(in_ch, channels[0], 3, padding=1)  # SPADE's input conv (its `fc`)
        chans = (channels[0], *channels, out_channels)
        self.blocks = nn.ModuleList(
            SPADEResBlock(a, b, feature_channels, spade_hidden, norm, use_spectral_norm,
                          spade_kernel)
            for a, b in zip(chans[:-1], chans[1:], strict=True)
        )
        self.n_levels = len(channels)
        self.feature_channels = feature_channels
        self.output_activation = output_activation

    @classmethod
    def from_config(cls, cfg: GeneratorConfig) -> SPADEGenerator:
        return cls(**vars(cfg))  # the config's fields are the constructor's arguments

    def forward(self, features: torch.Tensor, max_opacity: torch.Tensor) -> torch.Tensor:
        fs, fm = tuple(features.shape), tuple(max_opacity.shape)
        if fs[-2:] != fm[-2:] or fs[1] != self.feature_channels or fm[1] != 1:
            raise ValueError(f"bad shapes: F_s {fs}, F_max {fm}")
        sizes = level_sizes(tuple(features.shape[-2:]), self.n_levels)
        conds = {s: resize(features, s) for s in sizes}  # F_s resized once per level
        x = resize(max_opacity, sizes[0])  # (B, 1, H/4, W/4) for the paper
        if self.concat_features:
            x = torch.cat((x, conds[sizes[0]]), dim=1)  # (B, 1 + C_a+2, H/4, W/4)
        x = self.fc(x)  # (B, channels[0], H/4, W/4)
        for i, block in enumerate(self.blocks):
            size = sizes[min(i, len(sizes) - 1)]
            if tuple(x.shape[-2:]) != size:
                x = F.interpolate(x, size=size, mode="nearest")  # SPADE upsamples by 2 (nearest)
            x = block(x, conds[size])
        return torch.tanh(x) if self.output_activation == "tanh" else torch.sigmoid(x)
