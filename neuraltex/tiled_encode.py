"""Patch-wise encoding: textons of a dense picture from E_s run on overlapping tiles.

E_s finds at most ``num_queries`` elements per call at its training size, and a picture with
more (71 bricks in data/real_textures/brick.png) comes out of one call as blobs
(:mod:`neuraltex.tiled_segments`). Here the picture is seen at ``zoom`` times the scale of
:meth:`TextonAutoencoder.encode` (its short side ``zoom x native_size`` px), cut into tiles of
the model's training size that overlap by a quarter, and

1. E_s labels each tile: every pixel goes to its query's segment where that query is
   effective (p > 0.5, eq. 4.5), else to no segment;
2. the tiles' segments are merged into one labelling (:func:`merge_tiles`), and the pieces of
   elements that the zoomed view split are joined where the whole-picture run holds them in
   one segment and no image edge runs between them (:mod:`neuraltex.split_merge`);
3. E_FC runs once on the zoomed picture, and E_g estimates one texton per merged segment
   (eqs. 4.3-4.7) from its mask (the hard segment, blurred by one pixel). Every segment's
   texton exists (p = delta = 1: it came from an effective query of its tile); texton 0 holds
   the pixels of no segment and never exists (p = delta = 0), as a non-effective query of
   the whole-picture run.

Textons are resolution independent, so the result decodes, edits and vectorizes like any
other; it just holds more (and smaller) of them. :func:`encode_image` holds the rule for when
to tile: the whole-picture run gives at least :data:`neuraltex.tiled_segments.DENSE` segments.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from neuraltex.coords import default_window
from neuraltex.estimation import estimate_textons, existence_probability, painter_order
from neuraltex.model import Encoded, TextonAutoencoder
from neuraltex.segmenters import soft_masks
from neuraltex.split_merge import merge_split
from neuraltex.tiled_segments import DENSE, TILING, consecutive, merge_tiles, tile_origins

ZOOM = 2  # tiles see the picture at twice encode()'s scale (validation split: MODEL.md)
MOST = 1024  # segments at most (the 25 real textures give 80-370; noise at 8:1 gave 2,587)
BATCH = 8  # tiles per E_s call


Tiling = Literal["auto", "on", "off"]  # one of TILING


def encode_image(model: TextonAutoencoder, image: Tensor, tile: Tiling = "auto",
                 zoom: float = ZOOM, dense_from: int = DENSE) -> Encoded:
    """Image (1, 3, H, W) in [0, 1] -> textons, by :meth:`TextonAutoencoder.encode` on the
    whole picture (``tile="off"``), from tiles (``"on"``), or from tiles where the whole
    picture's encoding has at least ``dense_from`` segments (``"auto"``: a dense picture)."""
    if tile not in TILING:
        raise ValueError(f"tile must be one of {', '.join(TILING)}, got {tile!r}")
    whole = model.encode(image)
    if tile == "on" or (tile == "auto" and segment_count(whole) >= dense_from):
        return encode_tiled(model, image, zoom, whole)
    return whole


def mask_labels(enc: Encoded, size: tuple[int, int] | None = None) -> Tensor:
    """Labels (h, w) int64 of an encoding (batch size 1), at ``size`` (default: its masks'):
    each pixel goes to the texton whose mask S is largest there, + 1, or to 0 (no segment)
    where that texton is not effective (p <= 0.5)."""
    from neuraltex.segments import mask_argmax

    masks = enc.masks[0]
    if size is None or tuple(masks.shape[-2:]) == tuple(size):
        best = masks.argmax(0)  # (h, w)
    else:  # upsampled a chunk of masks at a time (memory bounded for hundreds of textons)
        best = torch.from_numpy(mask_argmax(masks, tuple(size))[0]).to(masks.device)
    effective = enc.textons.p[0] > 0.5  # (n,)
    return torch.where(effective[best], best + 1, torch.zeros_like(best))


def segment_count(enc: Encoded) -> int:
    """Segments of an encoding's masks: effective textons that win at least one pixel."""
    labels = mask_labels(enc)
    return int(torch.unique(labels[labels > 0]).numel())


def encode_tiled(model: TextonAutoencoder, image: Tensor, zoom: float = ZOOM,
                 whole: Encoded | None = None) -> Encoded:
    """Image (1, 3, H, W) in [0, 1] -> textons from tiles (module doc); ``whole``: the
    picture's :meth:`TextonAutoencoder.encode` (computed when not given), whose segments
    vouch for joining the pieces that tiles split. ``masks`` of the result are
    (1, 1 + K, h, w) at the estimation resolution of the zoomed picture, the first the pixels
    of no segment."""
    if image.dim() != 4 or image.shape[0] != 1:
        raise ValueError(f"tiled encoding takes one image (1, 3, H, W), got {tuple(image.shape)}")
    native = model.native_size
    est = model.estimation_size or native
    if not native or native % est:
        raise ValueError("tiled encoding needs a model with a training size that is a multiple "
                         f"of its estimation size (image_size={native}, estimation_size={est})")
    step = native // est  # picture pixels per estimation pixel
    H, W = image.shape[-2:]
    s = zoom * est / min(H, W)
    h, w = max(est, round(H * s)), max(est, round(W * s))  # estimation grid of the zoomed picture
    picture = F.interpolate(image, size=(h * step, w * step), mode="bilinear",
                            align_corners=False, antialias=h * step < H)
    labels = _tile_labels(model, picture, est, step)  # (h, w), 0 = no segment
    whole = model.encode(image) if whole is None else whole
    grey = F.avg_pool2d(picture.mean(1, keepdim=True), step)[0, 0]  # (h, w)
    labels = merge_split(labels, mask_labels(whole, (h, w)).cpu().numpy(), grey.cpu().numpy())
    labels = _at_most(labels, MOST)
    masks = soft_masks(labels).to(image)  # (1, 1 + K, h, w); channel 0 = no segment
    appearance, direction = model.encoder(picture * 2 - 1)
    appearance = F.interpolate(appearance, size=(h, w), mode="bilinear", align_corners=False)
    direction = F.interpolate(direction, size=(h, w), mode="bilinear", align_corners=False)
    t = estimate_textons(masks, appearance, direction, existence="all", eps=model.config.eps,
                         window=default_window(H, W))
    exists = torch.ones_like(t.p)
    exists[:, 0] = 0
    t = replace(t, p=exists, delta=exists, order=painter_order(t.cov))
    return Encoded(t, masks, appearance, direction)


def _tile_labels(model: TextonAutoencoder, picture: Tensor, est: int, step: int) -> np.ndarray:
    """Merged E_s labels (h, w) of ``picture`` (1, 3, h * step, w * step): tiles of
    ``est * step`` px (the training size) overlapping by a quarter, each labelled at the
    estimation resolution (``est`` px)."""
    h, w = picture.shape[-2] // step, picture.shape[-1] // step
    ys, xs = tile_origins(h, est, est // 4), tile_origins(w, est, est // 4)
    keys = [(i, j) for i in range(len(ys)) for j in range(len(xs))]
    parts = {}
    side = est * step
    for k in range(0, len(keys), BATCH):
        chunk = keys[k:k + BATCH]
        tiles = torch.cat([picture[..., ys[i] * step:ys[i] * step + side,
                                   xs[j] * step:xs[j] * step + side] for i, j in chunk])
        S = model.segment(tiles)  # (T, n, est, est)
        p = existence_probability(S.flatten(2))  # (T, n), eq. 4.5
        best = S.argmax(1)  # (T, est, est)
        effective = torch.gather(p > 0.5, 1, best.flatten(1)).view_as(best)
        labels = torch.where(effective, best + 1, torch.zeros_like(best)).cpu().numpy()
        parts.update(zip(chunk, labels, strict=True))
    return merge_tiles(parts, (h, w), ys, xs)


def _at_most(labels: np.ndarray, most: int) -> np.ndarray:
    """Labels (h, w) (0 = no segment, 1..K) with only the ``most`` largest segments: the
    pixels of the others go to the nearest kept one (bounds the textons and their masks,
    (1 + K, h, w) floats, on pictures of noise). Consecutive from 1 again."""
    area = np.bincount(labels.ravel())
    area[0] = 0
    if (area > 0).sum() <= most:
        return labels
    from scipy.ndimage import distance_transform_edt

    keep = np.zeros(len(area), bool)
    keep[np.argsort(-area, kind="stable")[:most]] = True
    kept = keep[labels]  # (h, w) in a kept segment ("no segment" pixels stay as they are)
    _, (iy, ix) = distance_transform_edt(~kept, return_indices=True)
    return consecutive(np.where(kept | (labels == 0), labels, labels[iy, ix]))
