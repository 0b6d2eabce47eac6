"""Masks S for the textons of one image, from the learned E_s or a classical segmenter.

E_g (eqs. 4.3-4.7) only needs soft masks S (1, K, H, W) that sum to 1 over K; where they come
from is a choice per image (``neuraltex fit --segmenter``):

- ``model``: the learned E_s, whose stride-4 masks are snapped to the image at full resolution
  (each fine superpixel takes the E_s label most of its pixels have: image-guided refinement);
- ``felzenszwalb`` / ``slic`` / ``kmeans``: classical segments at full resolution (k-means
  colour clusters are split into connected components, so each texton is one region);
(``neuraltex.fit`` adds ``auto``, which picks one of these per image by a measured criterion.)

The segment count adapts to the image: Felzenszwalb's scale grows until at most
``max_segments`` remain, so dense textures (gravel) get hundreds of textons, not a fixed 100.
"""

from __future__ import annotations

import math

import numpy as np
import torch
import torch.nn.functional as F

METHODS = ("model", "felzenszwalb", "slic", "kmeans")
MAX_SEGMENTS = 400  # default cap on textons per image
_MIN_AREA = 12      # pixels per segment at 256 x 256, scaled with the image area
SPLIT_SHARE = 1 / 128  # a segment larger than this share of the image is cut (split_large) ...
SPLIT_FLOOR = 400      # ... and than this many pixels (a 20 px sprite's texels: no blur below)
BACKGROUND = 0.25      # ... unless it covers this share: a backdrop stays one segment


def segment_labels(image: torch.Tensor, method: str, *, model=None,
                   max_segments: int = MAX_SEGMENTS, count: int | None = None,
                   queries: int | None = None) -> np.ndarray:
    """Segment labels of an image (3, H, W) in [0, 1] -> (H, W) int64 in 0..K-1. ``count``:
    the number of segments SLIC aims at (default: half of ``max_segments``); ``queries``:
    ``model``'s E_s with its queries resampled to this many (more, smaller textons)."""
    if method not in METHODS:
        raise ValueError(f"segmenter must be one of {METHODS}, got {method!r}")
    arr = image.permute(1, 2, 0).cpu().numpy().astype(np.float64)  # (H, W, 3)
    if method == "model":
        if model is None:
            raise ValueError("segmenter 'model' needs the model")
        if queries:
            from neuraltex.query_grid import with_queries

            model = with_queries(model, queries)
        return model_labels(model, image, max_segments)
    if method == "felzenszwalb":
        return split_large(felzenszwalb_labels(arr, max_segments), max_segments)
    if method == "slic":
        return slic_labels(arr, min(max_segments, count or max_segments // 2))
    return kmeans_labels(arr, max_segments)


def felzenszwalb_labels(arr: np.ndarray, max_segments: int, coarser: float = 1.0) -> np.ndarray:
    """Felzenszwalb-Huttenlocher segments, the scale raised until <= ``max_segments``; with
    ``coarser`` > 1, then segmented again at that many times the scale (larger segments that
    the finer ones nest in, e.g. the objects that several segments make)."""
    from skimage.segmentation import felzenszwalb

    area = arr.shape[0] * arr.shape[1] / 65536  # relative to 256 x 256
    scale, min_size = 100.0, max(_MIN_AREA, round(_MIN_AREA * area))
    for _ in range(12):
        labels = felzenszwalb(arr, scale=scale, sigma=0.8, min_size=min_size)
        if labels.max() + 1 <= max_segments:
            break
        scale, min_size = scale * 1.6, round(min_size * 1.4)
    if coarser > 1:
        labels = felzenszwalb(arr, scale=scale * coarser, sigma=0.8,
                              min_size=round(min_size * math.sqrt(coarser)))
    return _dense(labels)


def split_large(labels: np.ndarray, max_segments: int, share: float = SPLIT_SHARE,
                floor: int = SPLIT_FLOOR) -> np.ndarray:
    """Cut every segment larger than ``share`` of the image (512 px at 256 x 256) and than
    ``floor`` pixels into compact pieces of about that size (k-means on its pixel
    coordinates), largest first, while the count stays <= ``max_segments``; backdrops
    (>= BACKGROUND of the image) stay whole. A texton's detail sprite has as many texels as
    any other's, so one stretched over a large segment blurs it: measured on the 25 real
    textures (300 steps), mean PSNR 30.0 -> 32.1 dB, stone_wall 24.8 -> 26.9 dB.
    (H, W) int64 -> (H, W) int64 in 0..K'-1."""
    import warnings

    from scipy.cluster.vq import kmeans2

    H, W = labels.shape
    area = np.bincount(labels.ravel())
    limit, out, new = max(share * H * W, floor), labels.copy(), len(area)
    for k in np.argsort(-area, kind="stable"):
        free = max_segments - new
        if free <= 0 or area[k] <= limit:
            break
        if area[k] >= BACKGROUND * H * W:
            continue
        n = min(math.ceil(area[k] / limit), free + 1)
        ys, xs = np.nonzero(labels == k)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty cluster: one piece fewer
            _, piece = kmeans2(np.stack([xs, ys], 1).astype(float), n, minit="++", seed=0)
        out[ys, xs] = np.where(piece == 0, k, new + piece - 1)
        new += n - 1
    return _dense(out)


def slic_labels(arr: np.ndarray, n: int) -> np.ndarray:
    from skimage.segmentation import slic

    return _dense(slic(arr, n_segments=max(2, n), compactness=10.0, sigma=0.5, start_label=0,
                       channel_axis=-1))


def kmeans_labels(arr: np.ndarray, max_segments: int, k: int = 8, seed: int = 0) -> np.ndarray:
    """k-means colour clusters (Lab), split into connected regions; the smallest regions merge
    into a neighbour until at most ``max_segments`` remain."""
    from scipy.cluster.vq import kmeans2
    from skimage.color import rgb2lab
    from skimage.measure import label

    lab = rgb2lab(arr).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    sample = lab[rng.choice(len(lab), min(len(lab), 4096), replace=False)]
    k = min(k, len(np.unique(sample.round(3), axis=0)))  # no more clusters than colours
    centres, _ = kmeans2(sample, k, minit="++", seed=seed)
    colour = ((lab[:, None] - centres[None]) ** 2).sum(-1).argmin(1).reshape(arr.shape[:2])
    regions = label(colour, background=-1, connectivity=1)
    return _merge_small(_dense(regions), max_segments)


def model_labels(model, image: torch.Tensor, max_segments: int) -> np.ndarray:
    """E_s's argmax labels (the picture encoded as the commands do, from tiles where it is
    dense: :func:`neuraltex.tiled_encode.encode_image`), refined to the image's edges at full
    resolution."""
    from neuraltex.segments import mask_argmax
    from neuraltex.tiled_encode import encode_image

    H, W = image.shape[-2:]
    with torch.no_grad():
        enc = encode_image(model, image[None])
    keep = enc.textons.delta[0] > 0.5  # (n,) effective textons only
    masks = enc.masks[0][keep] if keep.any() else enc.masks[0]
    coarse = mask_argmax(masks, (H, W))[0]
    arr = image.permute(1, 2, 0).cpu().numpy().astype(np.float64)
    return _dense(refine_to_image(coarse, arr, max(max_segments, 4 * int(coarse.max() + 1))))


def refine_to_image(coarse: np.ndarray, arr: np.ndarray, superpixels: int) -> np.ndarray:
    """Each fine SLIC superpixel of the image takes the coarse label most of its pixels have,
    so label boundaries follow image edges at full resolution. (H, W) -> (H, W)."""
    fine = slic_labels(arr, superpixels).ravel()
    counts = np.zeros((fine.max() + 1, coarse.max() + 1), np.int64)
    np.add.at(counts, (fine, coarse.ravel()), 1)
    return counts.argmax(1)[fine].reshape(coarse.shape)


def soft_masks(labels: np.ndarray, softness: int = 1) -> torch.Tensor:
    """Hard labels (H, W) in 0..K-1 -> soft masks S (1, K, H, W) summing to 1 over K, with a
    ``softness``-pixel box blur across boundaries (E_g's moments need no more)."""
    lab = torch.from_numpy(np.ascontiguousarray(labels)).long()
    K = int(lab.max()) + 1
    m = torch.zeros(1, K, *lab.shape).scatter_(1, lab[None, None], 1.0)  # (1, K, H, W)
    if softness > 0:  # (float one-hot, no int64 copy: a tiled encoding has K in the hundreds)
        m = F.avg_pool2d(m, 2 * softness + 1, stride=1, padding=softness,
                         count_include_pad=False)
    return m.div_(m.sum(1, keepdim=True).clamp_min(1e-8))


def _dense(labels: np.ndarray) -> np.ndarray:
    return np.unique(labels, return_inverse=True)[1].reshape(labels.shape).astype(np.int64)


def _merge_small(labels: np.ndarray, max_segments: int) -> np.ndarray:
    """Merge the smallest regions into a larger neighbour until at most ``max_segments``
    remain."""
    while labels.max() + 1 > max_segments:
        K = labels.max() + 1
        area = np.bincount(labels.ravel(), minlength=K)
        small = set(np.argsort(area)[:K - max_segments].tolist())
        pairs = np.concatenate([np.stack([labels[:, :-1].ravel(), labels[:, 1:].ravel()], 1),
                                np.stack([labels[:-1].ravel(), labels[1:].ravel()], 1)])
        pairs = pairs[pairs[:, 0] != pairs[:, 1]]
        pairs = np.concatenate([pairs, pairs[:, ::-1]])
        target = np.arange(K)
        for a, b in pairs[np.isin(pairs[:, 0], list(small))]:
            if target[a] == a and b not in small:
                target[a] = b
        if (target == np.arange(K)).all():
            break
        labels = _dense(target[labels])
    return labels
