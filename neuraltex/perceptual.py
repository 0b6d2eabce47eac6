"""LPIPS for the reconstruction loss, without ever downloading anything.

The ``lpips`` package builds its AlexNet trunk through torchvision, which would fetch ImageNet
weights from the internet. Here the trunk is pretrained only when those weights already sit in
the local torch hub cache; otherwise (``backbone="auto"``) the trunk is randomly initialized and
one warning says so. The calibrated linear heads ship inside the ``lpips`` package and always
load. ``backbone_used`` records which trunk ran, for logs and the model card.
"""

from __future__ import annotations

import copy
import functools
import os
import warnings
from typing import Literal

import torch
from torch import nn

Backbone = Literal["auto", "pretrained", "random"]


def cached_alexnet_weights() -> str | None:
    """Path of torchvision's AlexNet ImageNet weights in the torch hub cache, if present."""
    from torchvision.models import AlexNet_Weights

    name = os.path.basename(AlexNet_Weights.IMAGENET1K_V1.url)
    path = os.path.join(torch.hub.get_dir(), "checkpoints", name)
    return path if os.path.isfile(path) else None


class LPIPS(nn.Module):
    """LPIPS distance (AlexNet trunk) on images in [0, 1]. Shape: (B, 3, H, W) x 2 -> (B,)."""

    def __init__(self, backbone: Backbone = "auto") -> None:
        super().__init__()
        cached = cached_alexnet_weights()
        if backbone == "pretrained" and cached is None:
            raise FileNotFoundError(
                "LPIPS backbone 'pretrained' needs torchvision's AlexNet weights in the torch hub "
                f"cache ({torch.hub.get_dir()}/checkpoints); use backbone=auto or random")
        use_pretrained = backbone == "pretrained" or (backbone == "auto" and cached is not None)
        if backbone == "auto" and not use_pretrained:
            _warn_random_trunk()
        self.backbone_used = "pretrained" if use_pretrained else "random"
        self.net = copy.deepcopy(_lpips_network(use_pretrained))

    def train(self, mode: bool = True) -> LPIPS:  # the metric network never trains
        super().train(False)
        return self

    def forward(self, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        return self.net(x * 2 - 1, y * 2 - 1).flatten()  # lpips expects [-1, 1]


@functools.lru_cache(maxsize=1)
def _warn_random_trunk() -> None:
    """The fallback is said once per process, not once per loss built."""
    warnings.warn("LPIPS: no pretrained AlexNet weights in the torch hub cache; using a "
                  "randomly initialized trunk (backbone=random)", stacklevel=4)


@functools.lru_cache(maxsize=2)
def _lpips_network(pretrained_trunk: bool) -> nn.Module:
    """The lpips network, built once per process (building AlexNet initializes its 58 M unused
    classifier weights: a second a time); :class:`LPIPS` takes copies."""
    import lpips

    # A fixed seed makes the random trunk the same network in every run and process.
    with torch.random.fork_rng(devices=[]), warnings.catch_warnings():
        torch.manual_seed(0)
        warnings.filterwarnings("ignore", category=UserWarning, module="torchvision")
        net = lpips.LPIPS(net="alex", pretrained=True, pnet_rand=not pretrained_trunk,
                          verbose=False)
    return net.eval().requires_grad_(False)
