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
    return _cost(a, b, masks_a.flatten(2), masks_b.flatten(2), weights, outer=True)


def pair_cost(a: Textons, b: Textons, masks_a: Tensor, masks_b: Tensor,
              weights: ConsistencyWeights = ConsistencyWeights()) -> Tensor:
    """C_ii of eq. 4.21: texton i of ``a`` against texton i of ``b`` (two aligned sets).

    masks_* (B, n, H, W) -> (B, n); equals the diagonal of :func:`matching_cost`.
    """
    return _cost(a, b, masks_a.flatten(2), masks_b.flatten(2), weights, outer=False)


def _cost(a: Textons, b: Textons, Sa: Tensor, Sb: Tensor, lam: ConsistencyWeights,
          outer: bool) -> Tensor:
    """eq. 4.21 on every pair i, j (``outer``: (B, n_a, n_b)) or on aligned pairs (B, n).
    Sa, Sb: the flattened masks (B, n, P)."""
    if outer:
        ea, eb, dist = (lambda t: t.unsqueeze(2)), (lambda t: t.unsqueeze(1)), torch.cdist
    else:
        def ea(t: Tensor) -> Tensor:
            return t
        eb = ea

        def dist(x: Tensor, y: Tensor) -> Tensor:
            return torch.linalg.vector_norm(x - y, dim=-1)
    w = ea(a.p) * eb(b.p)  # w_ij = p_i p_j
    beta = torch.minimum(ea(border_weight(a.mu, a.canvas, lam.border_margin)),
                         eb(border_weight(b.mu, b.canvas, lam.border_margin)))
    geo = (lam.mu * dist(a.mu, b.mu)
           + lam.cov * dist(a.cov.flatten(2), b.cov.flatten(2))
           + lam.v * dist(a.v, b.v)
           + lam.f * dist(a.f, b.f))
    dp = (ea(a.p) - eb(b.p)).abs()
    # Normalized by pixel count so lambda_S does not depend on the resolution.
    dS = dist(Sa, Sb) / Sa.shape[-1] ** 0.5
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

    The matching sees the whole (B, n, n) cost without autograd; the loss recomputes only the
    n matched pairs with it (the same value and gradient, without the backward of n^2
    mask distances).
    """
    if reduce not in ("sum", "mean"):
        raise ValueError(f"reduce must be 'sum' or 'mean', got {reduce!r}")
    with torch.no_grad():
        cost = matching_cost(transformed, encoded, masks_t, masks_e, weights).cpu().numpy()
    B, n = cost.shape[:2]
    rows, cols = torch.zeros(B, n, dtype=torch.long), torch.zeros(B, n, dtype=torch.long)
    weight = torch.zeros(B, n, dtype=torch.float64)  # a pair: 1 (sum) or 1 / pairs (mean)
    keep = [range(n)] * B if valid is None else [torch.nonzero(v).squeeze(1).tolist()
                                                  for v in valid.cpu()]
    for b in range(B):
        if len(keep[b]) == 0:
            continue
        r, c = linear_sum_assignment(cost[b, keep[b]])
        m = len(r)
        rows[b, :m], cols[b, :m] = torch.as_tensor(keep[b])[r], torch.as_tensor(c)
        weight[b, :m] = 1.0 if reduce == "sum" else 1.0 / m
    dev = masks_t.device
    rows, cols = rows.to(dev), cols.to(dev)
    pairs = pair_cost(transformed.index(rows), encoded.index(cols),
                      _gather(masks_t, rows), _gather(masks_e, cols), weights)
    return (pairs * weight.to(pairs)).sum() / B


def _gather(masks: Tensor, idx: Tensor) -> Tensor:
    """masks (B, n, H, W), idx (B, m) -> (B, m, H, W)."""
    return masks[torch.arange(masks.shape[0], device=masks.device).unsqueeze(1), idx]
