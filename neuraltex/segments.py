"""Image segments for vectorization, whatever made them: textons or a classical segmenter.

A :class:`Segments` is a label map plus a per-pixel margin (how clearly a pixel belongs to its
label, 0 at a boundary), a draw order, existence and a feature vector per segment. The
vectorizer (:mod:`neuraltex.vectorize`) only sees this, so the learned textons and the
Felzenszwalb baseline go through the same code path.

Textons give their segments from the segmentation masks S (the partition E_g estimates the
Gaussians from, eqs. 4.3-4.7) or from the composited splat weights (eq. 4.13, what the decoder
sees). Masks are the default: splat weights of a Gaussian are ellipses, so the traced outlines
would only repeat ``--mode ellipse``, and they fit the image worse (see docs/bridge.md).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch
import torch.nn.functional as F

from neuraltex.textons import Textons

SOURCES = ("masks", "splat")


@dataclass
class Segments:
    labels: np.ndarray  # (H, W) int64, 0..K-1, -1 = no segment (background layer shows)
    margin: np.ndarray  # (H, W) float32 >= 0: top-1 minus top-2 weight (1 for hard labels)
    order: np.ndarray  # (K,) draw order, larger = in front
    existence: np.ndarray  # (K,) in [0, 1]
    features: np.ndarray  # (K, D) for the kind clustering
    index: np.ndarray  # (K,) id in the source (texton index, segment label)

    def __post_init__(self) -> None:
        K = len(self.order)
        if self.labels.shape != self.margin.shape or self.labels.ndim != 2:
            raise ValueError(f"labels {self.labels.shape} and margin {self.margin.shape} "
                             "must be the same (H, W)")
        for name in ("existence", "features", "index"):
            if len(getattr(self, name)) != K:
                raise ValueError(f"Segments.{name}: expected {K} rows")
        if self.labels.max(initial=-1) >= K:
            raise ValueError("labels refer to more segments than given")

    @property
    def count(self) -> int:
        return len(self.order)


def from_weights(weights: torch.Tensor, threshold: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Argmax labels and top-1 minus top-2 margins of soft weights; pixels whose best weight is
    below ``threshold`` get -1. Shape: (K, H, W) -> (H, W) int64, (H, W) float32."""
    if weights.shape[0] == 1:
        top = torch.cat([weights, torch.zeros_like(weights)])
    else:
        top = weights
    best = torch.topk(top, 2, dim=0)
    labels = best.indices[0].clone()
    labels[best.values[0] < threshold] = -1
    margin = (best.values[0] - best.values[1]).clamp_min(0)
    return labels.cpu().numpy().astype(np.int64), margin.cpu().numpy().astype(np.float32)


def mask_argmax(masks: torch.Tensor, size: tuple[int, int],
                chunk: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`from_weights` of masks (K, h, w) upsampled (bilinear) to ``size`` and normalized
    over K, ``chunk`` masks at a time (default: 2^24 values per chunk): memory stays bounded
    however many textons a tiled encoding holds. Shape: -> (H, W) int64, (H, W) float32."""
    def up(m: torch.Tensor) -> torch.Tensor:
        return F.interpolate(m[None].float(), size=size, mode="bilinear",
                             align_corners=False)[0]

    chunk = chunk or max(1, 2**24 // (size[0] * size[1]))
    total = up(masks.sum(0, keepdim=True))[0].clamp_min(1e-8)  # interpolation is linear
    values = torch.full((2, *size), -1.0)
    index = torch.zeros((2, *size), dtype=torch.int32)
    for start in range(0, len(masks), chunk):
        w = up(masks[start:start + chunk]) / total  # (c, H, W)
        top = torch.topk(torch.cat([values, w.to(values)]), 2, dim=0)
        ids = torch.arange(start, start + len(w), dtype=torch.int32)[:, None, None]
        index = torch.cat([index, ids.expand(-1, *size)]).gather(0, top.indices)
        values = top.values
    margin = (values[0] - values[1].clamp_min(0)).clamp_min(0)
    return index[0].cpu().numpy().astype(np.int64), margin.cpu().numpy().astype(np.float32)


def from_labels(labels: np.ndarray, image: np.ndarray) -> Segments:
    """Hard labels (any ints) of an image (H, W, 3) in [0, 1]; e.g. Felzenszwalb segments.

    Larger segments are drawn first, so small ones sit on top of the ones around them. The
    features are the mean colour (Lab) and the log area, for the kind clustering.
    """
    from skimage.color import rgb2lab

    if labels.shape != image.shape[:2]:
        raise ValueError(f"labels {labels.shape} do not match the image {image.shape[:2]}")
    ids, dense = np.unique(labels, return_inverse=True)
    dense = dense.reshape(labels.shape).astype(np.int64)
    K = len(ids)
    area = np.bincount(dense.ravel(), minlength=K).astype(np.float64)
    lab = rgb2lab(np.clip(image, 0, 1)).reshape(-1, 3)
    mean = np.stack([np.bincount(dense.ravel(), lab[:, c], K) for c in range(3)], 1) / area[:, None]
    feats = np.concatenate([mean / 10, np.log(area)[:, None]], 1)  # (K, 4)
    order = np.argsort(np.argsort(-area, kind="stable"), kind="stable")
    return Segments(dense, np.ones(labels.shape, np.float32), order, np.ones(K), feats, ids)


def from_textons(textons: Textons, masks: torch.Tensor, size: tuple[int, int],
                 source: str = "masks", cutoff: float | None = None) -> Segments:
    """Segments of the effective textons of one set at ``size`` = (H, W).

    ``masks`` (n, h, w) are the softmax masks of :meth:`TextonAutoencoder.encode` (n = K).
    ``source="masks"``: each pixel goes to the effective texton with the largest mask value;
    ``"splat"``: to the texton with the largest composited weight (eq. 4.13), pixels that no
    texton reaches (weight < 0.05) to the background.
    """
    if source not in SOURCES:
        raise ValueError(f"source must be one of {SOURCES}, got {source!r}")
    keep = torch.nonzero(textons.delta[0] > 0.5).flatten()  # (K',)
    H, W = size
    if source == "masks":
        labels, margin = mask_argmax(masks[keep], (H, W)) if len(keep) else _empty(H, W)
    else:
        from neuraltex.splatting import opacity_maps

        weights = opacity_maps(textons, (H, W), cutoff=cutoff)[0, keep]  # (K', H, W)
        labels, margin = from_weights(weights, 0.05) if len(keep) else _empty(H, W)
    t = textons.index(keep[None])
    return Segments(labels, margin, t.order[0].cpu().numpy(), t.p[0].cpu().numpy(),
                    t.f[0].float().cpu().numpy(), keep.cpu().numpy())


def from_texture(texture, model) -> tuple[torch.Tensor, Segments]:
    """(image (3, H, W), segments) of a texture file (:class:`neuraltex.texture_file.Texture`)
    tuned from ``model``: its fitted segments, coloured by its tuned reconstruction at the
    size it was fitted at."""
    from neuraltex.tuned_decoder import tuned_model

    with torch.no_grad():
        image = tuned_model(model, texture.generator).decode(texture.textons.to(
            next(model.parameters()).device), texture.labels.shape)[0]
    arr = image.permute(1, 2, 0).cpu().numpy().astype(np.float64)
    return image, from_labels(texture.labels, arr)


def _empty(H: int, W: int) -> tuple[np.ndarray, np.ndarray]:
    return np.full((H, W), -1, np.int64), np.zeros((H, W), np.float32)


def drop_background(seg: Segments, min_share: float = 0.1) -> Segments:
    """The largest segment becomes background (-1) when it touches all four image sides and
    covers ``min_share`` of the image: a backdrop, not an element (one element as large as
    the exemplar could not be rearranged by the synthesis). The mortar of a brick wall, a
    network of joints spanning the picture, covers about a fifth of it."""
    lab = seg.labels
    if seg.count < 2 or (lab < 0).all():
        return seg
    area = np.bincount(lab[lab >= 0], minlength=seg.count)
    k = int(area.argmax())
    sides = (lab[0], lab[-1], lab[:, 0], lab[:, -1])
    if area[k] < min_share * lab.size or not all((s == k).any() for s in sides):
        return seg
    return replace(seg, labels=np.where(lab == k, -1, lab))


def segment_image(image: torch.Tensor, method: str = "model", model=None,
                  source: str = "masks", background: bool = True,
                  tile: str = "auto") -> tuple[Segments, Textons | None]:
    """Segments of an image (3, H, W) in [0, 1] by the texton ``model`` (encoding the picture
    whole or from tiles as ``tile`` says, :func:`neuraltex.tiled_encode.encode_image`) or a
    classical segmenter (a name of :data:`neuraltex.baselines.METHODS`); also the textons
    when the model made them. With ``background`` a backdrop segment goes to the background
    layer (:func:`drop_background`).
    """
    H, W = image.shape[-2:]
    textons = None
    if method != "model":
        from neuraltex.baselines import get_segmenter

        arr = image.permute(1, 2, 0).cpu().numpy().astype(np.float64)
        seg = from_labels(get_segmenter(method)(arr), arr)
    else:
        from neuraltex.tiled_encode import encode_image

        with torch.no_grad():
            enc = encode_image(model, image[None], tile)
            seg = from_textons(enc.textons, enc.masks[0], (H, W), source, cutoff=model.cutoff)
        textons = enc.textons
    return (drop_background(seg) if background else seg), textons
