"""Revealing and modifying texture variations (seed 003, 4.4.3, eqs. 4.25-4.30).

Appearance: f*_i = f_bar + lambda_f (f_i - f_bar). Shape: with Cholesky factors L_i of U_i and
L_bar of U_bar, W_i = L_i L_bar^-1 maps the mean shape to U_i, and U*_i = W_i^lu U_bar
(W_i^lu)^T. lambda = 1 is the identity, 0 collapses every texton to the mean.
"""

from __future__ import annotations

from dataclasses import replace

import torch
from torch import Tensor

from neuraltex.textons import Textons


def effective_mean(x: Tensor, delta: Tensor) -> Tensor:
    """eqs. 4.25-4.26: mean over effective textons. x (B, K, ...), delta (B, K) -> (B, 1, ...)."""
    w = (delta > 0.5).to(x.dtype)
    w = w.reshape(w.shape + (1,) * (x.dim() - 2))
    return (w * x).sum(1, keepdim=True) / w.sum(1, keepdim=True).clamp_min(1)


def lower_triangular_power(W: Tensor, lam: float) -> Tensor:
    """W^lam for lower-triangular 2x2 W with positive diagonal. (..., 2, 2) -> (..., 2, 2).

    The eigenvalues are the diagonal (a, d), so W^lam = [[a^lam, 0], [c s, d^lam]] with
    s = (a^lam - d^lam) / (a - d), or lam a^(lam - 1) when a == d.
    """
    a, c, d = W[..., 0, 0], W[..., 1, 0], W[..., 1, 1]
    al, dl = a.pow(lam), d.pow(lam)
    close = (a - d).abs() <= 1e-6 * (a.abs() + d.abs())
    s = torch.where(close, lam * a.pow(lam - 1), (al - dl) / torch.where(close, 1.0, a - d))
    zero = torch.zeros_like(a)
    return torch.stack([torch.stack([al, zero], -1), torch.stack([c * s, dl], -1)], -2)


def vary(textons: Textons, appearance: float = 1.0, shape: float = 1.0,
         keep: int = 0) -> Textons:
    """Scale the variation of appearance features (lambda_f) and shapes (lambda_U). The first
    ``keep`` channels of f are left as they are: pass C_a for the textons of a tuned decoder
    (neuraltex.fit), whose G was tuned to render each texton's own code f_a, so that a code
    between codes decodes to noise; their appearance then varies through the channels that
    add up in pixels, the colour offsets d and the detail sprites."""
    t = textons
    f_bar = effective_mean(t.f, t.delta)
    f = f_bar + appearance * (t.f - f_bar)  # eq. 4.27
    f = torch.cat([t.f[..., :keep], f[..., keep:]], dim=-1)
    cov = t.cov
    if shape != 1.0:
        U_bar = effective_mean(t.cov, t.delta)  # (B, 1, 2, 2)
        # A set without effective textons has no mean shape (and draws nothing): use them all.
        empty = ~t.exists().any(1).reshape(-1, 1, 1, 1)
        U_bar = torch.where(empty, t.cov.mean(1, keepdim=True), U_bar)
        L = torch.linalg.cholesky(t.cov)        # eq. 4.28
        L_bar = torch.linalg.cholesky(U_bar)
        W = L @ torch.linalg.inv(L_bar)         # eq. 4.29
        Wl = lower_triangular_power(W, shape)
        cov = Wl @ U_bar @ Wl.transpose(-1, -2)  # eq. 4.30
        cov = 0.5 * (cov + cov.transpose(-1, -2))
    return replace(t, f=f, cov=cov)
