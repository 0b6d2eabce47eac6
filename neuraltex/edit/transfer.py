"""Texture transfer (seed 003, 4.4.2, appendix 7.4): geometry from one texture, appearance
from another.

``mean`` (default): shift the structure texture's features so their mean over effective
textons equals the appearance texture's. ``replace``: every effective structure texton takes
the feature of a random effective appearance texton. With region masks, each texton (by its
centre) takes the appearance assigned to its region.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal

import torch
from torch import Tensor

from neuraltex.edit.vary import effective_mean
from neuraltex.textons import Textons

Mode = Literal["mean", "replace"]


def transfer(structure: Textons, appearance: Textons, mode: Mode = "mean",
             seed: int = 0) -> Textons:
    """Per set b: structure[b] with the appearance of appearance[b] (or appearance[0])."""
    if appearance.batch_size not in (1, structure.batch_size):
        raise ValueError("appearance must have batch size 1 or that of structure")
    if appearance.feature_dim != structure.feature_dim:
        raise ValueError("structure and appearance textons have different feature sizes")
    app = [appearance[b if appearance.batch_size > 1 else 0] for b in range(structure.batch_size)]
    f = torch.stack([_transfer_one(structure[b], app[b], mode, seed + b)[0]
                     for b in range(structure.batch_size)])
    return replace(structure, f=f)


def transfer_regions(structure: Textons, appearances: list[Textons], regions: Tensor,
                     mode: Mode = "mean", seed: int = 0) -> Textons:
    """Region-wise transfer for a single set. ``regions`` (H, W) int in [0, len(appearances));
    texton i takes appearances[regions at mu_i]."""
    if structure.batch_size != 1:
        raise ValueError("transfer_regions works on one texton set")
    regions = torch.as_tensor(regions)
    f = structure.f[0].clone()
    for r, app in enumerate(appearances):
        inside = structure.in_region(regions == r)[0]
        if inside.any():
            sub = structure.filter(inside.unsqueeze(0))
            new = _transfer_one(sub, app[0:1], mode, seed + r)[0]
            f[inside] = new[: int(inside.sum())]
    return replace(structure, f=f.unsqueeze(0))


def _transfer_one(s: Textons, a: Textons, mode: Mode, seed: int) -> Tensor:
    """Features (1, K, C) for one structure set s given one appearance set a."""
    if mode == "mean":
        return s.f - effective_mean(s.f, s.delta) + effective_mean(a.f, a.delta)
    if mode != "replace":
        raise ValueError(f"unknown transfer mode {mode!r}")
    pool = a.f[0][a.delta[0] > 0.5]
    if len(pool) == 0:
        pool = a.f[0]
    g = torch.Generator().manual_seed(seed)
    pick = torch.randint(len(pool), (s.num_textons,), generator=g).to(pool.device)
    f = s.f.clone()
    eff = s.delta[0] > 0.5
    f[0, eff] = pool[pick[eff]]
    return f

