"""Kinds of textons, and the background layer, so edits trade appearance only between
compatible textons.

Reshuffling (seed 003, 4.4.1) permutes appearance features f among textons. Over a whole real
texture that swaps the feature of the grout, or of a backdrop, with the feature of one small
element, and the decoder paints a large blob. So textons are grouped first:

- the **background layer**: effective textons whose Gaussian covers at least ``background``
  of the canvas (area of a uniform region with covariance U: 4 pi sqrt(det U));
- **kinds**: k-means over (log area, f) of the other effective textons, each kind split into
  bins of area (a factor of ``size_ratio``), so a texton never takes the feature of one four
  times larger or smaller, and into bins of shape: elongation (aspect ratio, a factor of 2)
  and, for elongated Gaussians, the direction of the long axis (four bins of 45 degrees), so
  a piece of a vertical seam never takes the look of a horizontal one (textons that carry
  detail sprites, :mod:`neuraltex.texton_detail`, show it along their long axis).

A texton of kind -1 never trades its feature.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import Tensor

from neuraltex.textons import Textons

BACKGROUND_SHARE = 0.25


def texton_area(textons: Textons) -> Tensor:
    """Area of the region each Gaussian stands for: 4 pi sqrt(det U). (B, K)."""
    return 4 * math.pi * torch.linalg.det(textons.cov).clamp_min(0).sqrt()


def texton_kinds(textons: Textons, *, max_kinds: int = 6, background: float = BACKGROUND_SHARE,
                 size_ratio: float = 4.0, seed: int = 0, channels: int | None = None,
                 shapes: bool = True) -> Tensor:
    """(B, K) int64: kind >= 0 of each effective texton, -1 for the background layer and for
    textons that do not exist (delta <= 0.5). ``channels``: how many leading channels of f
    the kinds compare (default all; pass the decoder's feature width to leave detail sprites
    out, :mod:`neuraltex.texton_detail`); ``shapes``: also split kinds by elongation and
    direction (:func:`shape_bins`)."""
    from scipy.cluster.vq import kmeans2

    kinds = torch.full(textons.p.shape, -1, dtype=torch.int64)
    area = texton_area(textons).detach().cpu().double()
    canvas = textons.canvas[0] * textons.canvas[1]
    for b in range(textons.batch_size):
        idx = torch.nonzero((textons.delta[b] > 0.5).cpu() & (area[b] < background * canvas))
        idx = idx.flatten()
        n = len(idx)
        if n == 0:
            continue
        k = max(1, min(max_kinds, round(math.sqrt(n / 5))))
        log_area = area[b, idx].clamp_min(1e-12).log().numpy()
        z = (log_area - log_area.mean()) / (log_area.std() + 1e-6)
        f = textons.f[b, idx, :channels].detach().cpu().double().numpy()
        feats = np.concatenate([z[:, None], f], 1)
        if k == 1 or n <= k:
            labels = np.zeros(n, np.int64)
        else:
            _, labels = kmeans2(feats, k, minit="++", seed=seed)
        # and never across a factor of ``size_ratio`` in area: a kind is split into size bins
        bins = np.floor(log_area / math.log(size_ratio)).astype(np.int64)
        keys = [labels, bins - bins.min()]
        if shapes:
            keys += shape_bins(textons.cov[b, idx].detach().cpu().double())
        labels = np.unique(np.stack(keys, 1), axis=0, return_inverse=True)[1].reshape(-1)
        kinds[b, idx] = torch.from_numpy(np.asarray(labels, np.int64))
    return kinds.to(textons.device)


def shape_bins(cov: Tensor, elongated: float = 1.5) -> list[np.ndarray]:
    """(elongation bin, direction bin) of Gaussians cov (n, 2, 2): floor(log2 aspect) capped
    at 3, with aspect = sqrt(l1 / l2); and for aspect >= ``elongated`` the long axis's angle
    in [0, 180) degrees rounded to 0, 45, 90 or 135 (bin 0..3), else -1."""
    lam, vec = torch.linalg.eigh(cov)
    aspect = (lam[:, 1] / lam[:, 0].clamp_min(1e-18)).sqrt().numpy()
    elong = np.minimum(np.floor(np.log2(np.maximum(aspect, 1.0))), 3).astype(np.int64)
    angle = np.arctan2(vec[:, 1, 1].numpy(), vec[:, 0, 1].numpy()) % math.pi
    direction = np.round(angle / (math.pi / 4)).astype(np.int64) % 4
    return [elong, np.where(aspect >= elongated, direction, -1)]
