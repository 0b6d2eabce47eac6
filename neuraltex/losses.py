"""Training losses of the Gaussian-texton autoencoder (seed 003, 4.3.2.3-4.3.6, appendix 7.7.2).

Small named functions; the trainer weighs and schedules them. Images are (B, 3, H, W) in
[0, 1]; masks S are (B, n, H, W), softmax-normalized over n.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from neuraltex.coords import pixel_grid
from neuraltex.nn_utils import sort_last
from neuraltex.perceptual import LPIPS, Backbone


def entropy_loss(masks: Tensor) -> Tensor:
    """eq. 4.8: mean over pixels of -sum_i S_i log S_i; 0 for hard masks."""
    return -(masks * torch.log(masks.clamp_min(1e-12))).sum(dim=1).mean()


def compactness_loss(masks: Tensor, mu: Tensor) -> Tensor:
    """eqs. 4.9-4.10: p_hat(p) = sum_i mu_i S_i(p); mean over pixels of |p - p_hat(p)|^2.

    masks (B, n, H, W), mu (B, n, 2) in the coordinates of :mod:`neuraltex.coords`.
    """
    B, n, H, W = masks.shape
    p_hat = torch.einsum("bnp,bnc->bpc", masks.reshape(B, n, H * W), mu)  # (B, HW, 2)
    grid = pixel_grid(H, W, device=masks.device, dtype=masks.dtype)
    return (grid - p_hat).square().sum(-1).mean()


class ReconstructionLoss(nn.Module):
    """eq. 4.15: L_R = w_l1 * L1 + w_lpips * LPIPS (defaults 2 and 0.2).

    ``mask`` (B, 1, H, W) restricts the loss to valid pixels (e.g. inside a transformed image).
    """

    def __init__(self, w_l1: float = 2.0, w_lpips: float = 0.2,
                 backbone: Backbone = "auto") -> None:
        super().__init__()
        self.w_l1, self.w_lpips = w_l1, w_lpips
        self.lpips = LPIPS(backbone) if w_lpips > 0 else None

    def forward(self, x: Tensor, y: Tensor, mask: Tensor | None = None) -> Tensor:
        if mask is None:
            l1 = (x - y).abs().mean()
        else:
            l1 = ((x - y).abs() * mask).sum() / (mask.sum() * x.shape[1]).clamp_min(1)
            x, y = x * mask, y * mask
        if self.lpips is None:
            return self.w_l1 * l1
        return self.w_l1 * l1 + self.w_lpips * self.lpips(x, y).mean()


def sliced_wasserstein_patches(x: Tensor, y: Tensor, patch: int = 2, projections: int = 64,
                               scales: int = 3, generator: torch.Generator | None = None) -> Tensor:
    """Patch-based texture loss L_T: sliced Wasserstein distance between the distributions of
    ``patch`` x ``patch`` pixel patches of x and y, summed over ``scales`` octaves.

    Needs no pretrained network. x (B, 3, H, W), y (B, 3, H', W') -> scalar. The trainer
    grows ``patch`` 2 -> 4 -> 6 (appendix 7.7.2). Under autocast it runs in float32:
    bfloat16 projections tie (8 mantissa bits), which coarsens the quantiles and slows the
    sort (a (4, 64, 3481) argsort 25 ms against 17 ms in float32, 2 threads).
    """
    if torch.is_autocast_enabled(x.device.type):
        with torch.autocast(x.device.type, enabled=False):
            return sliced_wasserstein_patches(x.float(), y.float(), patch, projections, scales,
                                              generator)
    total = x.new_zeros(())
    for s in range(scales):
        if s:
            x, y = F.avg_pool2d(x, 2), F.avg_pool2d(y, 2)
        if min(x.shape[-2:]) < patch or min(y.shape[-2:]) < patch:
            break
        px = F.unfold(x, patch)  # (B, D, L)
        py = F.unfold(y, patch)
        D = px.shape[1]
        dirs = torch.randn(D, projections, generator=generator).to(x)
        dirs = dirs / dirs.norm(dim=0, keepdim=True)
        # projections (B, M, L), sorted along the contiguous last dim
        qx, qy = sort_last(dirs.T @ px), sort_last(dirs.T @ py)
        if qy.shape[-1] != qx.shape[-1]:  # compare quantiles when patch counts differ
            qy = F.interpolate(qy, size=qx.shape[-1], mode="linear", align_corners=True)
        total = total + (qx - qy).square().mean()
    return total


def d_logistic_loss(real_pred: Tensor, fake_pred: Tensor) -> Tensor:
    """Discriminator loss of the non-saturating GAN (StyleGAN2)."""
    return F.softplus(-real_pred).mean() + F.softplus(fake_pred).mean()


def g_nonsaturating_loss(fake_pred: Tensor) -> Tensor:
    """eqs. 4.16 / 4.20: -log D(fake) = softplus(-D(fake))."""
    return F.softplus(-fake_pred).mean()


def d_r1_loss(real_pred: Tensor, real_input: Tensor) -> Tensor:
    """R1 penalty: E |grad_x D(x)|^2 on real inputs (``real_input`` must require grad).

    Lazy regularization (every k steps) multiplies it by gamma / 2 * k in the trainer.
    """
    (grad,) = torch.autograd.grad(real_pred.sum(), real_input, create_graph=True)
    return grad.square().flatten(1).sum(1).mean()
