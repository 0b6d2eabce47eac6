"""Appearance reshuffling: swap texton features, keep texton geometry (seed 003, 4.3.5.1, 4.4.1).

Training uses the soft swap of eqs. 4.17-4.19: texton i receives the feature of texton pi(i)
for a random permutation pi, blended by a swap coefficient

    tau_ij = min(1, max(A_j / A_i, p_j / p_i) ** gamma)              eq. 4.18

so an effective texton (area A and existence p well above 0) only takes features from other
effective textons, while ineffective ones may take anything (they are not rendered). gamma = 0
is a hard permutation. Inference (diversification) permutes features among effective textons
only (delta = 1), exactly.
"""

from __future__ import annotations

from dataclasses import replace

import torch
from torch import Tensor

from neuraltex.textons import Textons

_TINY = 1e-8


def swap_coefficients(p: Tensor, perm: Tensor, gamma: float = 0.5,
                      area: Tensor | None = None) -> Tensor:
    """tau_{i, perm(i)} of eq. 4.18. p, area (B, K); perm (B, K) int64 -> (B, K) in [0, 1]."""
    ratio = torch.gather(p, 1, perm) / p.clamp_min(_TINY)
    if area is not None:
        ratio = torch.maximum(ratio, torch.gather(area, 1, perm) / area.clamp_min(_TINY))
    if gamma == 0:
        return torch.ones_like(ratio)
    return ratio.clamp_min(0).pow(gamma).clamp(max=1.0)


def soft_reshuffle(textons: Textons, *, gamma: float = 0.5, area: Tensor | None = None,
                   generator: torch.Generator | None = None) -> Textons:
    """Training-time reshuffle, eqs. 4.17-4.19: f~ = (1 - tau) f + tau P f (differentiable).

    ``area``: mask areas A_i = sum_p S_i(p), shape (B, K); without it only p is used, which the
    seed reports is sufficient.
    """
    B, K = textons.p.shape
    perm = torch.stack([torch.randperm(K, generator=generator) for _ in range(B)])
    perm = perm.to(textons.device)
    tau = swap_coefficients(textons.p, perm, gamma, area).unsqueeze(-1)  # (B, K, 1)
    donor = torch.gather(textons.f, 1, perm.unsqueeze(-1).expand_as(textons.f))  # P F
    f = (1 - tau) * textons.f + tau * donor  # eq. 4.19
    return replace(textons, f=f)


def reshuffle(textons: Textons, *, seed: int | None = None, threshold: float = 0.5,
              kinds: Tensor | None = None) -> Textons:
    """Diversify: permute appearance features among effective textons (delta > threshold).

    Geometry (mu, U), direction v, existence and draw order stay; only f moves, and only
    between effective textons of the same set. With ``kinds`` (B, K) int64 (see
    :func:`neuraltex.texton_kinds.texton_kinds`) f moves only between textons of the same kind,
    and textons of kind -1 (the background layer) keep theirs. Deterministic for a given
    ``seed``.
    """
    g = torch.Generator()
    if seed is not None:
        g.manual_seed(seed)
    else:
        g.seed()
    f = textons.f.clone()
    for b in range(textons.batch_size):
        effective = textons.delta[b] > threshold
        groups = [effective] if kinds is None else [
            effective & (kinds[b] == k) for k in kinds[b].unique().tolist() if k >= 0]
        for group in groups:
            idx = torch.nonzero(group).squeeze(1)
            perm = idx[torch.randperm(len(idx), generator=g).to(idx.device)]
            f[b, idx] = textons.f[b, perm]
    return replace(textons, f=f)
