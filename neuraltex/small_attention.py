"""Scaled dot-product attention for many small heads, with its backward in closed form.

E_s's decoder attends with 4 heads of 8 channels, 100 queries, 4-100 keys, batch 8 (tiny
preset). torch's fused CPU kernel (``F.scaled_dot_product_attention``) is blocked for long
sequences and wide heads: on these shapes its forward + backward took 0.8-2.9 ms a call on
this 2-core machine where batched matrix products, a softmax and their closed-form backward
take 0.45-1.5 ms (4-100 keys; docs/training_speed.md, session 23). The attention is the same:

    P = softmax(Q K^T / sqrt(d) with blocked keys at -inf),  O = P V

and its gradient, with delta_i = sum_c dO_ic O_ic (= sum_j dP_ij P_ij),

    dV = P^T dO,   dS = P * (dO V^T - delta) / sqrt(d),   dQ = dS K,   dK = dS^T Q.

The backward keeps P (G, n, L) where the fused kernel keeps a log-sum-exp per row and
computes P again: 1.3 MB a layer more for the tiny preset's self-attention at batch 8.
"""

from __future__ import annotations

import math

import torch
from torch import Tensor


class _SmallAttention(torch.autograd.Function):
    @staticmethod
    def forward(ctx, q: Tensor, k: Tensor, v: Tensor, blocked: Tensor | None) -> Tensor:
        *batch, n, d = q.shape
        L = k.shape[-2]
        q3, k3, v3 = (t.reshape(-1, t.shape[-2], d) for t in (q, k, v))  # (G, n|L, d)
        s = torch.bmm(q3, k3.transpose(1, 2)).mul_(1 / math.sqrt(d))  # (G, n, L)
        if blocked is not None:
            s.view(*batch, n, L).masked_fill_(blocked, float("-inf"))
        p = torch.softmax(s, dim=-1)
        o = _bmm_narrow(p, v3)  # (G, n, d)
        ctx.save_for_backward(q3, k3, v3, p, o)
        ctx.shapes = (q.shape, k.shape)
        return o.reshape(q.shape)

    @staticmethod
    def backward(ctx, grad: Tensor):
        q3, k3, v3, p, o = ctx.saved_tensors
        q_shape, k_shape = ctx.shapes
        # under autocast the forward's products ran in p's precision: so does the backward
        q3, k3, v3, do = (t.to(p.dtype) for t in (q3, k3, v3, grad.reshape(o.shape)))
        dv = _bmm_narrow(p.transpose(1, 2), do)  # (G, L, d)
        delta = (do * o).sum(-1, keepdim=True)  # (G, n, 1)
        ds = torch.bmm(do, v3.transpose(1, 2)).sub_(delta).mul_(p)  # (G, n, L)
        ds.mul_(1 / math.sqrt(q_shape[-1]))
        dq, dk = _bmm_narrow(ds, k3), _bmm_narrow(ds.transpose(1, 2), q3)
        return dq.reshape(q_shape), dk.reshape(k_shape), dv.reshape(k_shape), None


def _bmm_narrow(a: Tensor, b: Tensor) -> Tensor:
    """a @ b for a (G, r, c) and a narrow b (G, c, d), d = head channels -> (G, r, d). Over
    a long c as (b^T a^T)^T, a transposed view: the same products with the wide side as the
    output's rows, 2.4-3.6x faster in CPU GEMM for a (100, 100) @ (100, 8) block; over a
    short c (a few keys) the plain product is the faster."""
    if a.shape[-1] < 32:
        return torch.bmm(a, b)
    return torch.bmm(b.transpose(1, 2), a.transpose(1, 2)).transpose(1, 2)


def small_attention(q: Tensor, k: Tensor, v: Tensor, blocked: Tensor | None = None) -> Tensor:
    """softmax(q k^T / sqrt(d)) v with ``blocked`` keys at zero weight.

    Shape: q (B, h, n, d), k/v (B, h, L, d) (any strides), blocked None or bool broadcastable
    to (B, h, n, L), True = may not attend; every row needs a key that is not blocked ->
    (B, h, n, d)."""
    if blocked is not None:
        blocked = blocked.expand(*q.shape[:-1], k.shape[-2])
    return _SmallAttention.apply(q, k, v, blocked)
