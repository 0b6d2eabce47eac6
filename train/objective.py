"""One training step's losses as two modules (so each can be wrapped in DDP):

- :class:`GeneratorObjective` — E, h, G: eq. 4.24 (reconstruction, entropy, compactness,
  reshuffled texture + patch GAN, equivariance consistency + transformed reconstruction, image
  GAN, optional mask supervision);
- :class:`CriticObjective` — D and D_p: non-saturating GAN losses with lazy R1.

The critics are used by the generator objective but not registered in it (a plain tuple), so
DDP over the generator objective never touches their parameters.
"""

from __future__ import annotations

from typing import NamedTuple

import torch
from torch import Tensor, nn

from neuraltex.discriminators import PatchDiscriminator, random_crops
from neuraltex.estimation import estimate_textons
from neuraltex.losses import (
    ReconstructionLoss,
    compactness_loss,
    d_logistic_loss,
    d_r1_loss,
    entropy_loss,
    g_nonsaturating_loss,
    sliced_wasserstein_patches,
)
from neuraltex.model import Encoded, TextonAutoencoder
from neuraltex.reshuffle import soft_reshuffle
from train.consistency import consistency_loss
from train.loss_config import LossConfig, StepSettings
from train.mask_supervision import mask_supervision_loss
from train.transforms import random_affine, warp_images


class Outputs(NamedTuple):
    loss: Tensor
    logs: dict[str, float]
    recon: Tensor            # (B, 3, H, W) in [0, 1]
    reshuffled: Tensor | None
    encoded: object          # neuraltex.model.Encoded (None: a warm-up step without diagnostics)


class GeneratorObjective(nn.Module):
    def __init__(self, model: TextonAutoencoder, critics: CriticObjective,
                 loss: LossConfig) -> None:
        super().__init__()
        self.model, self.loss = model, loss
        self.recon = ReconstructionLoss(loss.w_l1, loss.w_lpips, loss.lpips_backbone)
        self._critics = (critics,)  # not a submodule: DDP over this module skips the critics

    @property
    def critics(self) -> CriticObjective:
        return self._critics[0]

    def forward(self, images: Tensor, labels: Tensor | None, w: StepSettings,
                g: torch.Generator) -> Outputs:
        """eq. 4.24, or with ``w.segmenter_only`` the warm-up in which only E_s learns the
        given segments (mask supervision gt or pseudo) and nothing is decoded."""
        opt, model = self.loss, self.model
        if w.segmenter_only:
            return self._segmenter_warmup(images, labels, w, g)
        size = tuple(images.shape[-2:])
        enc = model.encode(images, existence=w.existence, generator=g, native=False)
        z = enc.textons
        recon = model.decode(z, size)
        logs: dict[str, Tensor] = {}
        logs["recon"] = self.recon(recon, images)
        logs["entropy"] = entropy_loss(enc.masks)
        logs["compact"] = compactness_loss(enc.masks, z.mu)
        total = logs["recon"] + w.entropy * logs["entropy"] + w.compact * logs["compact"]
        if opt.gan:
            logs["gan"] = g_nonsaturating_loss(self.critics.image(recon))
            total = total + w.gan * logs["gan"]
        reshuffled = None
        if opt.reshuffle and w.reshuffle:
            h = reshuffled_count(images.shape[0])
            area = enc.masks[:h].flatten(2).sum(-1)
            zs = soft_reshuffle(z[:h], gamma=opt.reshuffle_gamma, area=area, generator=g)
            reshuffled = model.decode(zs, size)
            logs["texture"] = sliced_wasserstein_patches(reshuffled, images[:h],
                                                         patch=w.patch_size, generator=g)
            total = total + w.reshuffle * w.texture * logs["texture"]
            if opt.gan:
                ref = self.critics.crops(images[:h], g)
                fake = self.critics.crops(reshuffled, g)
                logs["pgan"] = g_nonsaturating_loss(self.critics.patch(ref, fake))
                total = total + w.reshuffle * w.pgan * logs["pgan"]
        if opt.equivariance and w.equivariance:
            csis, recon_t = self._equivariance(images, enc, w.existence, g)
            logs["csis"], logs["recon_t"] = csis, recon_t
            total = total + w.equivariance * (w.csis * csis + recon_t)
        if opt.mask_supervision != "none" and labels is not None:
            logs["mask"] = mask_supervision_loss(enc.masks, labels, opt.mask_points, g)
            total = total + w.mask * logs["mask"]
        logs["total"] = total
        out = {k: float(v.detach()) for k, v in logs.items()}
        out.update(_diagnostics(images, recon.detach(), enc, w.diagnostics))
        return Outputs(total, out, recon, reshuffled, enc)

    def _segmenter_warmup(self, images: Tensor, labels: Tensor | None, w: StepSettings,
                          g: torch.Generator) -> Outputs:
        """Warm-up: E_s learns the given segments; nothing is decoded (recon is blank)."""
        if labels is None:
            raise ValueError("a segmenter warm-up needs loss.mask_supervision=gt or pseudo")
        logits = self.model.segment_logits(images)  # (B, n, h, w)
        mask = mask_supervision_loss(logits, labels, self.loss.mask_points, g, logits=True)
        total = w.mask * mask
        logs = {"mask": float(mask.detach()), "total": float(total.detach())}
        if not w.diagnostics:  # a step nobody looks at: no geometry
            return Outputs(total, logs, torch.zeros_like(images), None, None)
        with torch.no_grad():  # geometry only, for the diagnostics and the overlay pictures
            masks = logits.float().softmax(dim=1)
            B, _, h, wd = masks.shape
            blank = masks.new_zeros(B, 1, h, wd)
            z = estimate_textons(masks, blank, blank.expand(B, 2, h, wd), existence="round")
        enc = Encoded(z, masks.detach(), blank, blank)
        logs.update(_diagnostics(images, None, enc))
        return Outputs(total, logs, torch.zeros_like(images), None, enc)

    def _equivariance(self, images: Tensor, enc, existence: str, g: torch.Generator):
        """L_csis (eqs. 4.21-4.23) between T(E(I)) and E(T(I)), and L'_R on T(I)."""
        model, z = self.model, enc.textons
        T = random_affine(images.shape[0], z.canvas, generator=g)
        T = type(T)(T.A.to(images), T.t.to(images))
        warped, valid = warp_images(images, T)
        z_t = z.affine(T.A.unsqueeze(1), T.t.unsqueeze(1))
        enc_t = model.encode(warped, existence=existence, generator=g, native=False)
        masks_t, valid_m = warp_images(enc.masks, T)
        inside = ((z_t.mu >= 0) & (z_t.mu <= torch.tensor(z.canvas).to(z_t.mu))).all(-1)
        csis = consistency_loss(z_t, enc_t.textons, masks_t * valid_m, enc_t.masks * valid_m,
                                valid=inside, weights=self.loss.csis_lambda,
                                reduce=self.loss.csis_reduce)
        recon_t = self.recon(model.decode(z_t, tuple(images.shape[-2:])), warped, mask=valid)
        return csis, recon_t


class CriticObjective(nn.Module):
    """D (image) and D_p (patches, conditioned on a real crop) with their losses.

    D_p judges ``patch.num_crops`` random crops per image of side ``patch.crop_size``, at most
    ``image_size`` (the training resolution).
    """

    def __init__(self, image: nn.Module, patch: PatchDiscriminator, loss: LossConfig,
                 image_size: int | None = None) -> None:
        super().__init__()
        self.image, self.patch, self.loss = image, patch, loss
        self.crop_size = min(patch.crop_size, image_size or patch.crop_size)

    def crops(self, images: Tensor, g: torch.Generator) -> Tensor:
        """(B, 3, H, W) -> (B * num_crops, 3, s, s) random crops for D_p."""
        return random_crops(images, self.crop_size, self.patch.num_crops, generator=g)

    def forward(self, images: Tensor, recon: Tensor, reshuffled: Tensor | None, step: int,
                g: torch.Generator, dp_weight: float = 1.0) -> tuple[Tensor, dict[str, float]]:
        """D's loss, D_p's on ``reshuffled`` (weighted by ``dp_weight``: the lazy reshuffle's
        k; none on a step without a reshuffle), and every ``r1_every`` steps the lazy R1."""
        opt = self.loss
        logs = {"d": d_logistic_loss(self.image(images), self.image(recon.detach()))}
        total = logs["d"]
        h = reshuffled_count(images.shape[0])
        real_ref = real = None
        if reshuffled is not None:
            real_ref = self.crops(images[:h], g)
            real = self.crops(images[:h], g)
            fake = self.crops(reshuffled.detach(), g)
            logs["dp"] = d_logistic_loss(self.patch(real_ref, real), self.patch(real_ref, fake))
            total = total + dp_weight * logs["dp"]
        k = opt.r1_every
        if k and step % k == 0:
            # Lazy R1 (StyleGAN2): every k steps, weighted by gamma / 2 * k.
            x = images.detach().requires_grad_(True)
            logs["r1"] = d_r1_loss(self.image(x), x)
            total = total + opt.r1_gamma_d / 2 * k * logs["r1"]
            if opt.reshuffle:
                if real is None:  # a step of the lazy reshuffle without one: crops of its own
                    real_ref, real = self.crops(images[:h], g), self.crops(images[:h], g)
                xr = real.detach().requires_grad_(True)
                logs["r1_p"] = d_r1_loss(self.patch(real_ref, xr), xr)
                total = total + opt.r1_gamma_dp / 2 * k * logs["r1_p"]
        return total, {k: float(v.detach()) for k, v in logs.items()}


def reshuffled_count(batch: int) -> int:
    """How many images of a batch are reshuffled (N/2, appendix 7.7.2): the generator's
    reshuffle and the patch critic's crops of real images for them."""
    return max(1, batch // 2)


@torch.no_grad()
def _diagnostics(images: Tensor, recon: Tensor | None, enc, full: bool = True
                 ) -> dict[str, float]:
    """Numbers that expose the three degenerate phases of CPU training: a fixed
    partition (masks identical across images), collapse (1-2 queries take all pixels), a dead
    start (no effective textons), and whether the decoder beats a constant image. Without
    ``full`` only the cheap ones (the per-pixel argmax costs ~3 % of a segmenter step)."""
    out = {"diag/effective": float((enc.textons.p > 0.5).sum(-1).float().mean())}  # as inference
    if recon is not None:
        out["diag/l1"] = float((recon - images).abs().mean())
    if not full:
        return out
    labels = enc.masks.argmax(1).flatten(1)  # (B, P)
    B = labels.shape[0]
    if B > 1:
        differ = (labels.unsqueeze(0) != labels.unsqueeze(1)).float().mean(-1)
        diversity = float(differ.sum() / (B * (B - 1)))
    else:
        diversity = 0.0
    used = [int(torch.unique(lab).numel()) for lab in labels]
    const = (images - images.mean(dim=(0, 2, 3), keepdim=True)).abs().mean()
    return out | {"diag/mask_diversity": diversity, "diag/queries_used": sum(used) / B,
                  "diag/l1_constant": float(const)}
