"""Gaussian parameter estimation E_g: segmentation masks + feature maps -> textons.

Seed 003, section 4.3.2.2, eqs. 4.3-4.7. Every statistic is a mask-weighted average over
pixels, computed as one batched matmul of the flattened masks (B, n, H*W) with a per-pixel
quantity, so nothing of size (B, n, H, W, C) is ever built.
"""

from __future__ import annotations

from typing import Literal

import torch
import torch.nn.functional as F
from torch import Tensor

from neuraltex.coords import Window, default_window, pixel_grid
from neuraltex.textons import Textons

Existence = Literal["sample", "round", "soft", "all"]

# Smallest total mask mass; a query with less is treated as this (avoids 0/0).
_MIN_MASS = 1e-8


def estimate_textons(
    masks: Tensor,
    appearance: Tensor,
    direction: Tensor,
    *,
    existence: Existence = "round",
    temperature: float = 1.0,
    eps: float = 1e-5,
    window: Window | None = None,
    generator: torch.Generator | None = None,
) -> Textons:
    """Estimate one Gaussian texton per segmentation mask.

    Shape:
        masks (B, n, H, W), softmax-normalized over n; appearance F_a (B, C, H, W);
        direction V (B, 2, H, W). Returns :class:`Textons` with K = n, C channels.

    ``existence`` picks delta: ``"sample"`` draws delta ~ Bernoulli(p) with the binary
    Gumbel-softmax straight-through estimator (training); ``"round"`` rounds p (inference);
    ``"soft"`` uses delta = p; ``"all"`` sets delta = 1 (a warm-up without existence gating).
    ``eps`` is added to the covariance diagonal (normalized units squared) for stability.
    ``window`` is the part of the plane the masks cover (default: the image, see coords).
    """
    if masks.dim() != 4:
        raise ValueError(f"masks must be (B, n, H, W), got {tuple(masks.shape)}")
    if torch.is_autocast_enabled(masks.device.type):  # moments in float32 (no bf16 LU/det)
        with torch.autocast(masks.device.type, enabled=False):
            return estimate_textons(masks.float(), appearance.float(), direction.float(),
                                    existence=existence, temperature=temperature, eps=eps,
                                    window=window, generator=generator)
    B, n, H, W = masks.shape
    for name, x, ch in (("appearance", appearance, None), ("direction", direction, 2)):
        if x.dim() != 4 or x.shape[0] != B or x.shape[2:] != (H, W) or (ch and x.shape[1] != ch):
            raise ValueError(f"{name} must be (B={B}, {ch or 'C'}, {H}, {W}), "
                             f"got {tuple(x.shape)}")
    window = default_window(H, W) if window is None else window
    S = masks.reshape(B, n, H * W)
    mass = S.sum(dim=-1).clamp_min(_MIN_MASS)  # (B, n): the normalizer sigma_i

    # Coordinates relative to the window centre keep the second moments well conditioned.
    centre = torch.tensor([(window[0] + window[2]) / 2, (window[1] + window[3]) / 2],
                          device=masks.device, dtype=masks.dtype)
    d = pixel_grid(H, W, window, device=masks.device, dtype=masks.dtype) - centre  # (HW, 2)
    moments = torch.cat([d, d[:, :1] * d, d[:, 1:] * d[:, 1:]], dim=1).T  # (5, HW): x y xx xy yy
    # The small per-pixel quantities share one pooling product, the wide appearance map has
    # its own (concatenating them would copy the whole appearance map).
    C = appearance.shape[1]
    small = torch.cat([moments.expand(B, -1, -1), direction.reshape(B, 2, -1)], dim=1)
    pooled = _MaskPool.apply(small, S).transpose(1, 2) / mass.unsqueeze(-1)  # (B, n, 7)
    mean = pooled[..., :2]                          # eq. 4.3 (still centred)
    cov = _covariance(pooled[..., 2:5], mean, eps)  # eq. 4.4
    v = F.normalize(pooled[..., 5:], dim=-1, eps=1e-12)  # eq. 4.7
    # A mask without a direction (empty, or cancelling directions) gets an arbitrary unit one,
    # so every texton set the encoder writes is valid (texton files require unit v).
    directed = pooled[..., 5:].norm(dim=-1, keepdim=True) > 1e-6
    v = torch.where(directed, v, v.new_tensor([1.0, 0.0]))
    f = _MaskPool.apply(appearance.reshape(B, C, -1), S).transpose(1, 2) / mass.unsqueeze(-1)
    f = F.normalize(f, dim=-1, eps=1e-12)           # eq. 4.6

    p = existence_probability(S, mass)
    delta = _existence(p, existence, temperature, generator)

    order = painter_order(cov)
    canvas = (window[2] - window[0], window[3] - window[1])
    return Textons(mu=mean + centre, cov=cov, v=v, f=f, p=p, delta=delta, order=order,
                   canvas=canvas)


def existence_probability(S: Tensor, mass: Tensor | None = None) -> Tensor:
    """Eq. 4.5, each mask's average weighted by itself: flattened masks S (B, n, P) -> p
    (B, n); ``mass``: S's sums over P clamped at _MIN_MASS, where the caller has them.
    sum S^2 as a squared norm: one pass over S, no (B, n, P) temporary."""
    if mass is None:
        mass = S.sum(dim=-1).clamp_min(_MIN_MASS)
    return torch.linalg.vector_norm(S, dim=-1).square() / mass


def painter_order(cov: torch.Tensor) -> torch.Tensor:
    """Draw order (eq. 4.13) from sizes: larger Gaussians behind smaller ones, (B, n, 2, 2) ->
    (B, n) int64 ranks (0 = back). The paper notes order is irrelevant without overlap; a
    background texton overlaps everything, and drawn in front it would hide the elements."""
    with torch.no_grad():
        area = torch.linalg.det(cov)  # (B, n)
        return torch.argsort(torch.argsort(area, dim=1, descending=True, stable=True), dim=1)


class _MaskPool(torch.autograd.Function):
    """Y = X S^T, sums of per-pixel quantities under every mask: X (B, D, P), S (B, n, P) ->
    (B, D, n). The backward writes both gradients straight into the layouts of X and S
    (autograd's default would build the mask gradient transposed, then copy it)."""

    @staticmethod
    def forward(ctx, X: Tensor, S: Tensor) -> Tensor:
        ctx.save_for_backward(X, S)
        return torch.bmm(X, S.transpose(1, 2))

    @staticmethod
    def backward(ctx, gY: Tensor):
        X, S = ctx.saved_tensors
        gX = torch.bmm(gY, S) if ctx.needs_input_grad[0] else None
        gS = torch.bmm(gY.transpose(1, 2).contiguous(), X) if ctx.needs_input_grad[1] else None
        return gX, gS


def _covariance(second: Tensor, mean: Tensor, eps: float) -> Tensor:
    """E[d d^T] - mu mu^T, projected to PSD, plus eps*I.

    second (B, n, 3) holding E[xx], E[xy], E[yy]; mean (B, n, 2) -> (B, n, 2, 2).
    """
    a = (second[..., 0] - mean[..., 0] ** 2).clamp_min(0)
    d = (second[..., 2] - mean[..., 1] ** 2).clamp_min(0)
    b = second[..., 1] - mean[..., 0] * mean[..., 1]
    # Cancellation in float32 can leave |b| slightly above sqrt(ad); clip so U stays PSD.
    lim = (a * d).clamp_min(0).sqrt()
    b = torch.maximum(torch.minimum(b, lim), -lim)
    row0 = torch.stack([a + eps, b], dim=-1)
    row1 = torch.stack([b, d + eps], dim=-1)
    return torch.stack([row0, row1], dim=-2)


def _existence(p: Tensor, mode: Existence, temperature: float,
               generator: torch.Generator | None) -> Tensor:
    if mode == "round":
        return (p > 0.5).to(p.dtype)
    if mode == "soft":
        return p
    if mode == "all":
        return torch.ones_like(p)
    if mode != "sample":
        raise ValueError(f"unknown existence mode {mode!r}")
    # Binary Gumbel-softmax: the difference of two Gumbel variables is logistic noise.
    u = torch.rand(p.shape, generator=generator, device=p.device, dtype=p.dtype)
    u = u.clamp(1e-6, 1 - 1e-6)
    q = p.clamp(1e-6, 1 - 1e-6)
    logits = torch.log(q) - torch.log1p(-q) + torch.log(u) - torch.log1p(-u)
    soft = torch.sigmoid(logits / temperature)
    hard = (soft > 0.5).to(p.dtype)
    # Straight-through: forward exactly hard (soft - soft is exactly 0), backward soft.
    return hard + (soft - soft.detach())
