"""Texture interpolation (seed 003, 4.4.4, eq. 4.31).

Textons of two sets are put in correspondence by the Hungarian algorithm on centre distance
plus existence difference; every parameter is blended convexly (a convex combination of SPD
covariances is SPD); the existence delta is drawn from Bernoulli(blended delta), so t = 0 and
t = 1 give back the endpoints exactly.
"""

from __future__ import annotations

from dataclasses import replace

import torch
import torch.nn.functional as F
from scipy.optimize import linear_sum_assignment
from torch import Tensor

from neuraltex.textons import Textons


def match(a: Textons, b: Textons) -> tuple[Textons, Textons]:
    """Pad both sets to K = max(K_a, K_b) and reorder ``b`` so texton i matches texton i of
    ``a`` (Hungarian algorithm on centre distance + existence difference, per set).

    A padding slot (a texton without partner) takes its partner's geometry and appearance,
    existence 0, so along a blend an unmatched texton fades in or out in place instead of
    sliding towards the origin. Pairing with padding costs only the existence term, so which
    textons stay unmatched depends on the others' best matching, not on where they sit.
    Shapes: (B, K_a) and (B, K_b) sets -> two (B, K) sets.
    """
    n_a, n_b = a.num_textons, b.num_textons
    k = max(n_a, n_b)
    a, b = a.pad_to(k), b.pad_to(k)
    real_a = torch.arange(k, device=a.device) < n_a
    real_b = torch.arange(k, device=b.device) < n_b
    dist = torch.cdist(a.mu, b.mu) * (real_a[:, None] & real_b[None, :])        # (B, K, K)
    cost = dist + (a.delta.unsqueeze(2) - b.delta.unsqueeze(1)).abs()
    idx = []
    for c in cost.detach().cpu().numpy():
        rows, cols = linear_sum_assignment(c)
        idx.append(torch.as_tensor(cols[rows.argsort()]))
    idx = torch.stack(idx).to(a.device)                                         # (B, K)
    b = b.index(idx)
    pad_b = idx >= n_b
    pad_a = (~real_a).expand_as(pad_b)
    return _adopt(a, b, pad_a), _adopt(b, a, pad_b)


def _adopt(t: Textons, partner: Textons, where: Tensor) -> Textons:
    """Where ``where`` (B, K): copy mu, cov, v, f of ``partner`` (existence stays)."""
    def pick(x: Tensor, y: Tensor) -> Tensor:
        return torch.where(where.reshape(where.shape + (1,) * (x.dim() - 2)), y, x)
    return replace(t, mu=pick(t.mu, partner.mu), cov=pick(t.cov, partner.cov),
                   v=pick(t.v, partner.v), f=pick(t.f, partner.f))


def blend(a: Textons, b: Textons, t: float | Tensor,
          generator: torch.Generator | None = None) -> Textons:
    """Convex blend of corresponding sets (same K). ``t``: a number or a (B, K) tensor."""
    t = torch.as_tensor(t, dtype=a.dtype, device=a.device)
    if t.dim() == 0:
        t = t.expand_as(a.p)
    t1, t2, t3 = t.unsqueeze(-1), t.unsqueeze(-1).unsqueeze(-1), t

    def mix(x: Tensor, y: Tensor, w: Tensor) -> Tensor:
        return (1 - w) * x + w * y

    prob = mix(a.delta, b.delta, t3).clamp(0, 1)
    u = torch.rand(prob.shape, generator=generator, dtype=prob.dtype).to(prob.device)
    delta = (u < prob).to(prob.dtype)
    v = F.normalize(mix(a.v, b.v, t1), dim=-1, eps=1e-12)
    v = torch.where(v.norm(dim=-1, keepdim=True) > 0.5, v, a.v)  # opposite directions
    order = torch.where(t3 < 0.5, a.order, b.order)
    canvas = tuple(float(x) for x in mix(torch.tensor(a.canvas), torch.tensor(b.canvas),
                                          float(t.mean())))
    return Textons(mu=mix(a.mu, b.mu, t1), cov=mix(a.cov, b.cov, t2), v=v,
                   f=mix(a.f, b.f, t1), p=mix(a.p, b.p, t3), delta=delta, order=order,
                   canvas=canvas)


def interpolate(a: Textons, b: Textons, t: float, seed: int = 0) -> Textons:
    """Interpolated textons at ``t`` in [0, 1] (0 -> a, 1 -> b)."""
    if not 0.0 <= t <= 1.0:
        raise ValueError(f"t must lie in [0, 1], got {t}")
    g = torch.Generator().manual_seed(seed)
    return blend(*match(a, b), t, g)


def interpolate_frames(a: Textons, b: Textons, frames: int, seed: int = 0) -> list[Textons]:
    """``frames`` sets from a to b; one correspondence and one noise draw for all frames, so
    a texton switches on or off only once along the sequence."""
    if frames < 2:
        raise ValueError("need at least 2 frames")
    a, matched = match(a, b)
    return [blend(a, matched, i / (frames - 1), torch.Generator().manual_seed(seed))
            for i in range(frames)]


def interpolate_spatially(a: Textons, b: Textons, seed: int = 0) -> Textons:
    """t grows linearly from 0 at the left edge to 1 at the right edge (by texton centre)."""
    a, matched = match(a, b)
    x = 0.5 * (a.mu[..., 0] + matched.mu[..., 0])
    t = (x / a.canvas[0]).clamp(0, 1)
    return blend(a, matched, t, torch.Generator().manual_seed(seed))
