"""Texton detail: a small RGB sprite per texton, drawn in the texton's own frame.

A tuned decoder G renders what the Gaussians and their features describe; the fine detail of
a real texture (the grain of a stone, the veins of a leaf, the edge of a brick) is more than
a few feature channels per texton can carry. So a fitted texton also carries a *sprite*
D_i (3, S, S): the residual image (input - G's decode) around it, resampled into its frame

    p = mu_i + A_i u,  u in [-1, 1]^2,  A_i A_i^T = REACH^2 U_i

so that M^2 = REACH^2 |u|^2 (eq. 4.11): the unit square covers the Gaussian out to
Mahalanobis distance M = REACH along the frame's axes. The detail image adds at each pixel
the sprites of the ``k`` textons with the largest composited weights a_i(p) (eq. 4.13),
normalized over them:

    r(p) = sum_k a_k(p) D_k(A_k^-1 (p - mu_k)) / max(sum_k a_k(p), FLOOR)

A sprite is appearance: it is stored after the texton's features, f = [f_a, d, vec(D)]
(:mod:`neuraltex.tuned_decoder`), so every edit that moves, permutes or blends features
(reshuffle, transfer, interpolation, variation) moves, permutes or blends the sprites the
same way, and every edit of the geometry (move, scale, rotate, animate) carries the sprite
along with the frame. The frame's first axis follows the Gaussian's long axis (or, for a round
one, the texton's direction v), so a rotated texton shows a rotated sprite.
"""

from __future__ import annotations

import math
from dataclasses import replace

import torch
import torch.nn.functional as F
from torch import Tensor

from neuraltex.coords import Window, default_window, pixel_grid
from neuraltex.splatting import top_weights
from neuraltex.textons import Textons

SPRITE = 16   # sprite side S, texels, when not chosen per texture (:func:`auto_side`)
TEXELS = 2.0  # auto_side: sprite texels per image pixel, over all textons
MIN_SIDE, MAX_SIDE = 8, 32
REACH = 2.0   # the sprite covers |u| <= 1 <-> M <= REACH along the frame's axes
TOP_K = 4     # textons blended per pixel
FLOOR = 0.25  # least total weight the blend divides by (fades detail where textons fade)
# (l1 - l2) / (l1 + l2) of U's eigenvalues below which a Gaussian counts as round (its sprite
# turns with v) and above which as elongated (its sprite lies along the long axis)
ROUND, ELONGATED = 0.1, 0.3
RIDGE = 1e-2  # Tikhonov weight of the sprite fit (keeps unseen texels at 0)


def sprite_side(channels: int) -> int | None:
    """S for ``channels`` = 3 S^2 detail channels (S >= 2), None for 0; ValueError else."""
    if channels == 0:
        return None
    s = math.isqrt(max(channels // 3, 0))
    if s < 2 or 3 * s * s != channels:
        raise ValueError(f"{channels} extra feature channels are not an RGB sprite (3 S^2)")
    return s


def auto_side(count: int, size: tuple[int, int], texels: float = TEXELS) -> int:
    """Sprite side for ``count`` textons on an image of ``size`` (H, W): ``texels`` sprite
    texels per pixel in all (a few large textons get large sprites, many small ones small
    ones), within [MIN_SIDE, MAX_SIDE]. At 256 x 256 px: 600 KB of float16 sprites."""
    side = round(math.sqrt(texels * size[0] * size[1] / max(count, 1)))
    return int(min(max(side, MIN_SIDE), MAX_SIDE))


def split(textons: Textons, plain: int) -> tuple[Textons, Tensor | None]:
    """Textons whose f is [f (``plain`` channels), vec(D)] -> (textons with the plain f,
    sprites (B, K, 3, S, S) or None)."""
    S = sprite_side(textons.feature_dim - plain)
    if S is None:
        return textons, None
    B, K = textons.p.shape
    sprites = textons.f[..., plain:].reshape(B, K, 3, S, S)
    return replace(textons, f=textons.f[..., :plain]), sprites


def attach(textons: Textons, sprites: Tensor) -> Textons:
    """The inverse of :func:`split`: f -> [f, vec(D)]. sprites (B, K, 3, S, S)."""
    return replace(textons, f=torch.cat([textons.f, sprites.flatten(2)], dim=-1))


def resize_sprites(textons: Textons, plain: int, side: int) -> Textons:
    """The textons (f = [f (``plain`` channels), vec(D)]) with their sprites resampled to
    ``side`` texels (bilinear), e.g. to mix textures fitted with different sprite sizes;
    textons without sprites get blank ones."""
    t, sprites = split(textons, plain)
    B, K = t.p.shape
    if sprites is None:
        sprites = t.f.new_zeros(B, K, 3, side, side)
    elif sprites.shape[-1] != side:
        sprites = F.interpolate(sprites.flatten(0, 1), size=(side, side), mode="bilinear",
                                align_corners=False).reshape(B, K, 3, side, side)
    return attach(t, sprites)


def frames(textons: Textons) -> Tensor:
    """A_i = REACH U_i^(1/2) Q_i: u = A_i^-1 (p - mu_i) has |u| = M / REACH, and the first
    axis A_i e_1 lies along the Gaussian's long axis (pointing the way of v_i) when the
    Gaussian is elongated, along v_i when it is round, blended in between. (B, K, 2, 2).

    Q is the rotation taking e_1 to U^(-1/2) r / |U^(-1/2) r| for that reference direction r:
    any A with A A^T = U maps the unit disc onto the Gaussian's M = 1 ellipse; this one turns
    with the texton (R U R^T, R v -> R A), and two elongated textons of one shape (bricks,
    blades) get their sprites the same way round whatever their directions v say."""
    lam, vec = torch.linalg.eigh(textons.cov)                     # ascending; (B,K,2), (B,K,2,2)
    root = lam.clamp_min(1e-12).sqrt()
    half = vec @ torch.diag_embed(root) @ vec.transpose(-1, -2)    # U^(1/2)
    inv_half = vec @ torch.diag_embed(1 / root) @ vec.transpose(-1, -2)
    major = vec[..., :, 1]                                        # (B, K, 2)
    major = torch.where((major * textons.v).sum(-1, keepdim=True) < 0, -major, major)
    ratio = (lam[..., 1] - lam[..., 0]) / (lam[..., 1] + lam[..., 0]).clamp_min(1e-12)
    w = ((ratio - ROUND) / (ELONGATED - ROUND)).clamp(0, 1).unsqueeze(-1)
    r = w * major + (1 - w) * textons.v
    e = F.normalize((inv_half @ r.unsqueeze(-1)).squeeze(-1), dim=-1, eps=1e-12)
    e = torch.where(e.norm(dim=-1, keepdim=True) > 0.5, e, torch.tensor([1.0, 0.0]).to(e))
    Q = torch.stack([e, torch.stack([-e[..., 1], e[..., 0]], -1)], dim=-1)  # columns e, e_perp
    return half @ Q * REACH


class DetailSampler:
    """Where every pixel of an H x W window samples which sprites, for one texton geometry:
    render(sprites) is then linear in the sprites (and differentiable w.r.t. them)."""

    def __init__(self, textons: Textons, size: tuple[int, int], window: Window | None = None,
                 cutoff: float | None = None, k: int = TOP_K) -> None:
        H, W = int(size[0]), int(size[1])
        window = default_window(H, W) if window is None else window
        with torch.no_grad():
            w, idx = top_weights(textons, (H, W), k, window=window, cutoff=cutoff)  # (B,k,H,W)
            w = w / w.sum(1, keepdim=True).clamp_min(FLOOR)
            B, K = textons.p.shape
            grid = pixel_grid(H, W, window, device=textons.device, dtype=textons.dtype)
            A_inv = torch.linalg.inv(frames(textons))                  # (B, K, 2, 2)
            flat = idx.flatten(1)                                      # (B, k*H*W)
            mu = torch.gather(textons.mu, 1, flat[..., None].expand(-1, -1, 2))
            Ai = torch.gather(A_inv.flatten(2), 1, flat[..., None].expand(-1, -1, 4))
            d = grid.repeat(k, 1).unsqueeze(0) - mu                    # (B, k*H*W, 2)
            Ai = Ai.reshape(*Ai.shape[:2], 2, 2)
            u = (Ai @ d.unsqueeze(-1)).squeeze(-1)                     # (B, k*H*W, 2)
            inside = (u.abs() <= 1).all(-1).reshape(B, k, H, W)
        self.weights = w * inside                                      # (B, k, H, W)
        self.index, self.u, self.size, self.K = idx, u, (H, W), K

    def render(self, sprites: Tensor) -> Tensor:
        """sprites (B, K, 3, S, S) -> detail image (B, 3, H, W)."""
        B, K, _, S, _ = sprites.shape
        H, W = self.size
        k = self.weights.shape[1]
        atlas = sprites.permute(0, 2, 1, 3, 4).reshape(B, 3, K * S, S)  # sprites stacked in y
        col = ((self.u[..., 0] + 1) / 2 * S - 0.5).clamp(0, S - 1)
        row = ((self.u[..., 1] + 1) / 2 * S - 0.5).clamp(0, S - 1)
        row = row + self.index.flatten(1).to(row.dtype) * S               # into its cell
        g = torch.stack([(col + 0.5) / S * 2 - 1, (row + 0.5) / (K * S) * 2 - 1], dim=-1)
        out = F.grid_sample(atlas, g.reshape(B, k * H, W, 2), mode="bilinear",
                            padding_mode="border", align_corners=False)  # (B, 3, k*H, W)
        return (out.reshape(B, 3, k, H, W) * self.weights.unsqueeze(1)).sum(2)

    def fit(self, residual: Tensor, side: int = SPRITE, iters: int = 40,
            ridge: float = RIDGE) -> Tensor:
        """Least-squares sprites: argmin |render(D) - residual|^2 + ridge |D|^2
        (:func:`fit_sprites` with this one layout). residual (B, 3, H, W) -> (B, K, 3, S, S)."""
        return fit_sprites([self], [residual], None, side, iters, ridge)


def fit_sprites(samplers: list[DetailSampler], residuals: list[Tensor],
                weights: list[Tensor | None] | None = None, side: int = SPRITE,
                iters: int = 40, ridge: float = RIDGE) -> Tensor:
    """Sprites that explain several layouts of the same textons at once:
    argmin sum_l |W_l^(1/2) (render_l(D) - residual_l)|^2 + ridge |D|^2, by conjugate
    gradients on the normal equations; each render is linear, so its transpose is its
    vector-Jacobian product. samplers: one per layout (the same K textons, moved);
    residuals (B, 3, H, W) each; weights: per layout None or a per-pixel weight (H, W)
    (0 where the layout's target is unknown). Texels are kept in [-1, 1], the range of a
    residual (a larger value only makes up for a tiny weight, and would flare where the
    texton moves). -> (B, K, 3, S, S)."""
    with torch.enable_grad():
        return _conjugate_gradients(samplers, residuals, weights or [None] * len(samplers),
                                    side, iters, ridge)


def _conjugate_gradients(samplers, residuals, weights, side, iters, ridge) -> Tensor:
    """:func:`fit_sprites` (gradients on: each transpose is a vector-Jacobian product)."""
    B, ref = residuals[0].shape[0], residuals[0]
    shape = (B, samplers[0].K, 3, side, side)

    def transpose(sampler: DetailSampler, image: Tensor) -> Tensor:  # render^T image
        zero = torch.zeros(shape, dtype=ref.dtype, device=ref.device, requires_grad=True)
        (g,) = torch.autograd.grad(sampler.render(zero), zero, grad_outputs=image)
        return g

    def weigh(image: Tensor, w: Tensor | None) -> Tensor:
        return image if w is None else image * w

    def normal(x: Tensor) -> Tensor:  # (sum_l A_l^T W_l A_l + ridge I) x
        x = x.detach().requires_grad_(True)
        out = ridge * x.detach()
        for sampler, w in zip(samplers, weights, strict=True):
            image = sampler.render(x)
            (g,) = torch.autograd.grad(image, x, grad_outputs=weigh(image.detach(), w))
            out = out + g
        return out

    b = sum(transpose(s, weigh(r, w)) for s, r, w in zip(samplers, residuals, weights,
                                                         strict=True))
    x = torch.zeros(shape, dtype=ref.dtype, device=ref.device)
    r = b.clone()
    p, rr = r.clone(), (r * r).sum()
    for _ in range(iters):
        if rr <= 1e-12:
            break
        q = normal(p)
        alpha = rr / (p * q).sum().clamp_min(1e-30)
        x, r = x + alpha * p, r - alpha * q
        rr_new = (r * r).sum()
        p, rr = r + rr_new / rr * p, rr_new
    return x.clamp(-1, 1)


def render_detail(textons: Textons, sprites: Tensor, size: tuple[int, int],
                  window: Window | None = None, cutoff: float | None = None) -> Tensor:
    """The detail image of textons (f without sprites) and their sprites (B, K, 3, S, S)
    -> (B, 3, H, W)."""
    return DetailSampler(textons, size, window, cutoff).render(sprites)
