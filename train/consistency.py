"""Equivariance consistency between T(E(I)) and E(T(I)) (seed 003, 4.3.5.2, eqs. 4.21-4.23).

Both texton sets live in the frame of the transformed image; their masks are given on the same
pixel grid (the trainer warps the original masks with T). The matching sigma is the Hungarian
assignment on the detached cost; the loss is the sum of the matched (differentiable) costs.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from scipy.optimize import linear_sum_assignment
from torch import Tensor

from neuraltex.textons import Textons


@dataclass(frozen=True)
class ConsistencyWeights:
    """lambda values of eq. 4.21 (section 4.3.5.2)."""

    mu: float = 1.2
    cov: float = 2.0
    v: float = 10.0
    f: float = 0.01
    p: float = 4.0
    masks: float = 200.0
    border_margin: float = 0.1  # beta ramps from 0.1 to 1 over this distance to the border


def border_weight(mu: Tensor, canvas: tuple[float, float], margin: float) -> Tensor:
    """beta_i in [0.1, 1]: lower for textons near the image border. mu (B, K, 2) -> (B, K)."""
    w, h = canvas
    dist = torch.stack([mu[..., 0], w - mu[..., 0], mu[..., 1], h - mu[..., 1]], -1).amin(-1)
    return (dist / margin).clamp(0.1, 1.0)


def matching_cost(a: Textons, b: Textons, masks_a: Tensor, masks_b: Tensor,
                  weights: ConsistencyWeights = ConsistencyWeights()) -> Tensor:
    """Cost matrix C_ij of eq. 4.21 between textons i of ``a`` and j of ``b``.

    masks_* (B, n, H, W) on the same pixel grid -> (B, n_a, n_b).
    """
    lam = weights
    w = a.p.unsqueeze(2) * b.p.unsqueeze(1)  # w_ij = p_i p_j
    beta = torch.minimum(border_weight(a.mu, a.canvas, lam.border_margin).unsqueeze(2),
                         border_weight(b.mu, b.canvas, lam.border_margin).unsqueeze(1))
    geo = (lam.mu * torch.cdist(a.mu, b.mu)
           + lam.cov * torch.cdist(a.cov.flatten(2), b.cov.flatten(2))
           + lam.v * torch.cdist(a.v, b.v)
           + lam.f * torch.cdist(a.f, b.f))
    dp = (a.p.unsqueeze(2) - b.p.unsqueeze(1)).abs()
    Sa, Sb = masks_a.flatten(2), masks_b.flatten(2)
    # Normalized by pixel count so lambda_S does not depend on the resolution.
    dS = torch.cdist(Sa, Sb) / Sa.shape[-1] ** 0.5
    return w * beta * geo + lam.p * dp + lam.masks * dS


def consistency_loss(transformed: Textons, encoded: Textons, masks_t: Tensor, masks_e: Tensor,
                     valid: Tensor | None = None,
                     weights: ConsistencyWeights = ConsistencyWeights(),
                     reduce: str = "sum") -> Tensor:
    """eqs. 4.22-4.23: minimum-cost matching between T(E(I)) and E(T(I)), averaged over B.

    ``valid`` (B, n) marks the textons of ``transformed`` that stayed inside the image; the
    others are left out of the matching (they have no counterpart in E(T(I))).
    ``reduce="sum"`` is eq. 4.22 (the matched costs summed); ``"mean"`` averages them, which
    keeps the loss's scale independent of the number of queries n.
    """
    if reduce not in ("sum", "mean"):
        raise ValueError(f"reduce must be 'sum' or 'mean', got {reduce!r}")
    cost = matching_cost(transformed, encoded, masks_t, masks_e, weights)
    total = cost.new_zeros(())
    for b in range(cost.shape[0]):
        rows = torch.arange(cost.shape[1]) if valid is None else torch.nonzero(valid[b]).squeeze(1)
        if len(rows) == 0:
            continue
        sub = cost[b, rows.to(cost.device)]
        r, c = linear_sum_assignment(sub.detach().cpu().numpy())
        matched = sub[torch.as_tensor(r), torch.as_tensor(c)]
        total = total + (matched.sum() if reduce == "sum" else matched.mean())
    return total / cost.shape[0]
