"""Edit propagation (seed 003, 4.4.5.2): a pixel edit made on one texton, repeated on the
textons that look like it.

1. The difference image D = edited - original holds the edit in pixel space.
2. The edited texton s is the Gaussian nearest (Mahalanobis) to the |D|-weighted centre of
   the changed pixels.
3. Targets are the other effective textons whose appearance feature has cosine similarity
   >= ``threshold`` with f_s.
4. For each target j, the affine map x -> A_j (x - mu_s) + mu_j with A_j U_s A_j^T = U_j
   (turned so that A_j v_s points along v_j) carries the source Gaussian onto the target's;
   D, cut to the source's neighbourhood (Mahalanobis distance <= ``radius``), is warped by it
   and added to the image.

The seed propagates in pixel space on purpose: novel content such as text is not reproduced
well through the latent features.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import torch
import torch.nn.functional as F
from torch import Tensor

from neuraltex.coords import default_window, pixel_grid
from neuraltex.edit.texton_edits import select_point, select_similar
from neuraltex.errors import InputError
from neuraltex.textons import Textons

# Pixels whose largest channel changed by less than this are not part of the edit.
MIN_CHANGE = 2 / 255
# Targets warped at once (each holds a (3, H, W) image).
_CHUNK = 16


class Propagation(NamedTuple):
    image: Tensor    # (3, H, W) the edited image with the edit repeated on every target
    source: int      # index of the edited texton
    targets: Tensor  # (K,) bool, textons that received a copy of the edit


def sqrtm_spd(cov: Tensor) -> Tensor:
    """Symmetric square root of SPD matrices. (..., 2, 2) -> (..., 2, 2)."""
    vals, vecs = torch.linalg.eigh(cov)
    return vecs @ torch.diag_embed(vals.clamp_min(1e-12).sqrt()) @ vecs.transpose(-1, -2)


def align_gaussians(cov_s: Tensor, v_s: Tensor, cov_t: Tensor, v_t: Tensor) -> Tensor:
    """A with A U_s A^T = U_t and A v_s parallel to v_t: A = U_t^1/2 R U_s^-1/2, R the
    rotation taking the whitened source direction onto the whitened target direction.

    Shape: cov (..., 2, 2), v (..., 2) -> (..., 2, 2).
    """
    root_s, root_t = sqrtm_spd(cov_s), sqrtm_spd(cov_t)
    w_s = torch.linalg.solve(root_s, v_s.unsqueeze(-1)).squeeze(-1)
    w_t = torch.linalg.solve(root_t, v_t.unsqueeze(-1)).squeeze(-1)
    angle = torch.atan2(w_t[..., 1], w_t[..., 0]) - torch.atan2(w_s[..., 1], w_s[..., 0])
    c, s = angle.cos(), angle.sin()
    R = torch.stack([torch.stack([c, -s], -1), torch.stack([s, c], -1)], -2)
    return root_t @ R @ torch.linalg.inv(root_s)


def edited_texton(textons: Textons, diff: Tensor, min_change: float = MIN_CHANGE) -> int:
    """Index of the Gaussian nearest to the edit in ``diff`` (3, H, W)."""
    H, W = diff.shape[-2:]
    weight = diff.abs().sum(0) * (diff.abs().amax(0) > min_change)  # (H, W)
    if not bool(weight.any()):
        raise InputError("the edited image does not differ from the original")
    grid = pixel_grid(H, W, _window(textons, H, W), dtype=diff.dtype)  # (H*W, 2)
    centre = (grid * weight.reshape(-1, 1)).sum(0) / weight.sum()
    mask = select_point(textons, *centre.tolist())
    if not bool(mask.any()):
        raise InputError("the image has no effective texton to propagate from")
    return int(mask.nonzero()[0, 0])


def propagate_edit(original: Tensor, edited: Tensor, textons: Textons, threshold: float = 0.9,
                   radius: float = 3.0, min_change: float = MIN_CHANGE,
                   channels: int | None = None) -> Propagation:
    """Repeat the edit (original -> edited, both (3, H, W)) on similar textons.

    ``textons``: one set (batch size 1) encoded from ``original``; ``channels``: how much of
    their f the similarity compares (:func:`select_similar`).
    """
    if original.shape != edited.shape or original.dim() != 3:
        raise InputError(f"original {tuple(original.shape)} and edited "
                         f"{tuple(edited.shape)} images must have the same size")
    t = textons.to(device=original.device, dtype=original.dtype)
    diff = edited - original
    s = edited_texton(t, diff, min_change)
    targets = select_similar(t, s, threshold, channels).to(original.device)
    targets[s] = False
    H, W = original.shape[-2:]
    grid = pixel_grid(H, W, _window(t, H, W), device=diff.device, dtype=diff.dtype)
    d = grid - t.mu[0, s]
    m2 = (d @ torch.linalg.inv(t.cov[0, s]) * d).sum(-1)                          # eq. 4.11
    support = (m2 <= radius * radius).reshape(H, W)
    patch = diff * support                                                        # (3, H, W)
    out = edited.clone()
    idx = targets.nonzero().flatten()
    for chunk in idx.split(_CHUNK):
        out += _warp(patch, t, s, chunk, grid, (H, W)).sum(0)
    return Propagation(out.clamp(0, 1), s, targets)


def _warp(patch: Tensor, t: Textons, s: int, idx: Tensor, grid: Tensor,
          size: tuple[int, int]) -> Tensor:
    """``patch`` carried from texton s onto each texton in ``idx``. -> (T, 3, H, W)."""
    H, W = size
    A = align_gaussians(t.cov[0, s], t.v[0, s], t.cov[0, idx], t.v[0, idx])      # (T, 2, 2)
    # Each output pixel x reads the source at A^-1 (x - mu_j) + mu_s.
    src = torch.linalg.solve(A.unsqueeze(1), (grid - t.mu[0, idx].unsqueeze(1)).unsqueeze(-1))
    src = src.squeeze(-1) + t.mu[0, s]                                            # (T, HW, 2)
    x0, y0, x1, y1 = _window(t, H, W)
    uv = torch.stack([(src[..., 0] - x0) / (x1 - x0), (src[..., 1] - y0) / (y1 - y0)], -1)
    uv = (uv * 2 - 1).reshape(len(idx), H, W, 2)  # grid_sample's [-1, 1], pixel centres
    return F.grid_sample(patch.expand(len(idx), -1, -1, -1), uv, mode="bilinear",
                         padding_mode="zeros", align_corners=False)


def _window(t: Textons, H: int, W: int):
    w, h = default_window(H, W)[2:]
    if not (math.isclose(w, t.canvas[0], rel_tol=1e-3)
            and math.isclose(h, t.canvas[1], rel_tol=1e-3)):
        raise InputError(f"textons describe a {t.canvas[0]:g} x {t.canvas[1]:g} canvas, "
                         f"not a {W}x{H} image")
    return default_window(H, W)
