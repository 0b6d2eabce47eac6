"""Image stylization (seed 003, 4.4.2): textons of a large content image from overlapping
patches, merged in the overlaps, features mean-aligned to a texture, decoded.

Patches of ``scale * P`` content pixels (P: the model's input resolution) are resized to P x P
and encoded; their textons are scaled back into the content's normalized coordinates. So
``scale`` < 1 gives smaller textons and ``scale`` > 1 larger ones (the seed's scale control).
Patches are merged in raster order: textons of the new patch and of the merged set whose
centres lie where the new patch overlaps earlier ones are put in correspondence (Hungarian, as
for interpolation) and blended with t rising from 0 at the patch border to 1 at the inner edge
of the overlap: a spatial interpolation (4.4.4) across every seam.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import torch
import torch.nn.functional as F
from torch import Tensor

from neuraltex.edit.interpolate import blend, match
from neuraltex.edit.transfer import Mode, transfer
from neuraltex.textons import Textons

Box = tuple[int, int, int]  # (y0, x0, side) in content pixels


def patch_starts(length: int, side: int, stride: int) -> list[int]:
    """Start offsets of windows of ``side`` covering [0, length), the last one flush."""
    if side >= length:
        return [0]
    starts = list(range(0, length - side, stride))
    return starts + [length - side]


def encode_patches(model, image: Tensor, side: int, size: int, overlap: float = 0.25,
                   batch: int = 16, progress: Callable[[Iterable], Iterable] = iter
                   ) -> tuple[Textons, list[Box]]:
    """Encode overlapping ``side``-pixel patches of ``image`` (3, H, W) at ``size`` x ``size``.

    Returns one texton set per patch, already in the content's normalized coordinates
    (B = number of patches), and the patch boxes in raster order.
    """
    H, W = image.shape[-2:]
    side = min(side, H, W)
    stride = max(1, round(side * (1 - overlap)))
    boxes = [(y, x, side) for y in patch_starts(H, side, stride)
             for x in patch_starts(W, side, stride)]
    short = float(min(H, W))
    sets = []
    for i in progress(range(0, len(boxes), batch)):
        crops = torch.stack([image[:, y:y + s, x:x + s] for y, x, s in boxes[i:i + batch]])
        crops = F.interpolate(crops, size=(size, size), mode="bilinear", antialias=True,
                              align_corners=False)  # (b, 3, P, P)
        with torch.no_grad():
            t = model.encode(crops).textons  # patch units: the patch side is 1
        shift = torch.tensor([[x / short, y / short] for y, x, _ in boxes[i:i + batch]],
                             dtype=t.dtype, device=t.device).unsqueeze(1)  # (b, 1, 2)
        sets.append(t.affine(torch.eye(2) * (side / short), shift))
    merged = Textons.cat(sets, dim=0)
    merged.canvas = (W / short, H / short)
    return merged, boxes


def merge_patches(patches: Textons, boxes: list[Box], short: int, seed: int = 0) -> Textons:
    """One texton set from per-patch sets (B = len(boxes)) laid out in raster order."""
    g = torch.Generator().manual_seed(seed)
    done, merged = [], patches[0]
    for i in range(1, len(boxes)):
        if boxes[i][0] != boxes[i - 1][0]:  # a new row: textons above it are final
            final = (merged.mu[0, :, 1] < boxes[i][0] / short)[None]
            done.append(merged.filter(final))
            merged = merged.filter(~final)
        new = patches[i]
        weight = _ramp(boxes, i, short)
        w_new = weight(new.mu[0])
        in_box = _inside(merged.mu[0], boxes[i], short)
        w_old = torch.where(in_box, weight(merged.mu[0]), torch.ones_like(in_box, dtype=new.dtype))
        seam_old, seam_new = w_old < 1, w_new < 1
        old, fresh = match(merged.filter(seam_old[None]), new.filter(seam_new[None]))
        t = weight(0.5 * (old.mu[0] + fresh.mu[0]))[None]  # (1, K) at the pair's midpoint
        merged = Textons.cat([merged.filter(~seam_old[None]), blend(old, fresh, t, g),
                              new.filter(~seam_new[None])], dim=1)
    merged = Textons.cat([*done, merged], dim=1)
    merged.canvas = patches.canvas
    return merged.existing() if bool(merged.exists().any()) else merged


def _inside(mu: Tensor, box: Box, short: int) -> Tensor:
    y, x, s = (c / short for c in box)
    return (mu[:, 0] >= x) & (mu[:, 0] < x + s) & (mu[:, 1] >= y) & (mu[:, 1] < y + s)


def _ramp(boxes: list[Box], i: int, short: int) -> Callable[[Tensor], Tensor]:
    """Weight of patch i at points (N, 2): 0 on its border with earlier patches, 1 past their
    overlap (the left neighbour in its row and the row above, as laid out by raster order)."""
    y, x, s = boxes[i]
    left = [b for b in boxes[:i] if b[0] == y and b[1] < x]
    above = [b for b in boxes[:i] if b[0] < y]
    x_end = max((b[1] + b[2] for b in left), default=x) / short  # right edge of the overlap
    y_end = max((b[0] + b[2] for b in above), default=y) / short
    x0, y0 = x / short, y / short

    def weight(p: Tensor) -> Tensor:  # (N, 2) -> (N,)
        return torch.minimum(_unit_ramp(p[:, 0], x0, x_end), _unit_ramp(p[:, 1], y0, y_end))

    return weight


def _unit_ramp(v: Tensor, start: float, end: float) -> Tensor:
    return ((v - start) / (end - start)).clamp(0, 1) if end > start else torch.ones_like(v)


def content_textons(model, image: Tensor, patch: int, scale: float = 1.0,
                    overlap: float = 0.25, seed: int = 0,
                    progress: Callable[[Iterable], Iterable] = iter) -> Textons:
    """Textons of a content image of any size (3, H, W), encoded patch by patch at ``patch``
    pixels with the scale control ``scale`` (patches of ``scale * patch`` content pixels)."""
    if scale <= 0 or not 0 <= overlap < 1:
        raise ValueError(f"need scale > 0 and 0 <= overlap < 1, got {scale}, {overlap}")
    side = max(4, round(scale * patch))
    sets, boxes = encode_patches(model, image, side, patch, overlap, progress=progress)
    return merge_patches(sets, boxes, min(image.shape[-2:]), seed)


def stylize(model, image: Tensor, texture: Textons | None, patch: int, scale: float = 1.0,
            overlap: float = 0.25, mode: Mode = "mean", seed: int = 0,
            progress: Callable[[Iterable], Iterable] = iter) -> Tensor:
    """Content image (3, H, W) rendered with the appearance of ``texture`` (its textons);
    without a texture, a patch-wise reconstruction of any size. -> (3, H, W)."""
    textons = content_textons(model, image, patch, scale, overlap, seed, progress)
    if texture is not None:
        textons = transfer(textons, texture.to(device=textons.device), mode, seed)
    with torch.no_grad():
        return model.decode(textons, tuple(image.shape[-2:]))[0]
