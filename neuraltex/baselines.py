"""Texton extraction methods behind one interface, for the benchmark.

A *segmenter* maps an image to a label map::

    segment(image: np.ndarray (H, W, 3) float in [0, 1]) -> np.ndarray (H, W) int

Every label is one predicted texton/segment (no special background label). Methods
are built from one main parameter, tuned on the validation split (see
``scripts/eval_textons.py --tune``); ``default`` is the value that tuning picked.
The learned model plugs in through :func:`model_segmenter` (``--method model``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neuraltex.errors import InputError

Segmenter = Callable[[np.ndarray], np.ndarray]


def _check_image(image: np.ndarray) -> None:
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must be (H, W, 3), got {image.shape}")


def grid_segmenter(cells: float) -> Segmenter:
    """A fixed grid, ``cells`` squares along the short side; ignores the image content."""

    def segment(image: np.ndarray) -> np.ndarray:
        _check_image(image)
        h, w = image.shape[:2]
        step = min(h, w) / cells
        rows = (np.arange(h) // step).astype(np.int64)
        cols = (np.arange(w) // step).astype(np.int64)
        return rows[:, None] * (int(w // step) + 1) + cols[None, :]

    return segment


def slic_segmenter(n_segments: float, compactness: float = 10.0) -> Segmenter:
    """SLIC superpixels; ``n_segments`` per unit area (short side = 1), so the same
    value fits every resolution of the resolution-independent textures."""
    from skimage.segmentation import slic

    def segment(image: np.ndarray) -> np.ndarray:
        _check_image(image)
        h, w = image.shape[:2]
        n = max(2, round(n_segments * h * w / min(h, w) ** 2))
        return slic(image.astype(np.float64), n_segments=n, compactness=compactness,
                    sigma=0.5, start_label=1, channel_axis=-1)

    return segment


def felzenszwalb_segmenter(scale: float, sigma: float = 0.8) -> Segmenter:
    """Felzenszwalb-Huttenlocher graph segmentation; ``scale`` (and min_size = 20 px)
    are given at 128 px and grow with the pixel area."""
    from skimage.segmentation import felzenszwalb

    def segment(image: np.ndarray) -> np.ndarray:
        _check_image(image)
        area = (min(image.shape[:2]) / 128.0) ** 2
        return felzenszwalb(image.astype(np.float64), scale=scale * area, sigma=sigma,
                            min_size=max(1, round(20 * area)), channel_axis=-1)

    return segment


def kmeans(points: np.ndarray, k: int, iters: int = 15, seed: int = 0) -> np.ndarray:
    """Lloyd's k-means with k-means++ seeding. Shape: (N, D) -> centres (k, D)."""
    rng = np.random.default_rng(seed)
    centres = [points[rng.integers(len(points))]]
    for _ in range(1, k):
        d2 = ((points[:, None, :] - np.array(centres)[None]) ** 2).sum(-1).min(1)
        if d2.sum() <= 0:
            break
        centres.append(points[rng.choice(len(points), p=d2 / d2.sum())])
    centres = np.array(centres)  # (k', D)
    for _ in range(iters):
        assign = ((points[:, None, :] - centres[None]) ** 2).sum(-1).argmin(1)  # (N,)
        for c in range(len(centres)):
            members = points[assign == c]
            if len(members):
                centres[c] = members.mean(0)
    return centres


def kmeans_segmenter(k: float, fit_pixels: int = 4096) -> Segmenter:
    """k-means on Lab colour (fit on a fixed random subset of pixels), then 4-connected
    components of each colour cluster."""
    from skimage.color import rgb2lab
    from skimage.measure import label

    def segment(image: np.ndarray) -> np.ndarray:
        _check_image(image)
        lab = rgb2lab(np.clip(image, 0, 1)).reshape(-1, 3).astype(np.float32)  # (H*W, 3)
        rng = np.random.default_rng(0)
        fit = lab[rng.choice(len(lab), min(fit_pixels, len(lab)), replace=False)]
        centres = kmeans(fit, int(k))
        # |x - c|^2 = |x|^2 - 2 x.c + |c|^2; |x|^2 does not change the argmin.
        clusters = (centres ** 2).sum(1)[None] - 2.0 * lab @ centres.T  # (H*W, k)
        clusters = clusters.argmin(1).reshape(image.shape[:2])
        return label(clusters, background=-1, connectivity=1)

    return segment


MODEL_LABELS = ("masks", "splats", "refined", "guided")


def model_segmenter(checkpoint: str, device: str = "cpu", labels: str = "masks",
                    num_queries: int | None = None,
                    guide: tuple[float, float] | None = None,
                    tile: str = "off", tile_from: int | None = None) -> Segmenter:
    """The learned texton model as a segmenter: the one hook the autoencoder plugs into.

    ``labels="masks"``: each pixel goes to the query whose mask S (E_s) is largest there, i.e.
    the segment its texton was estimated from (eqs. 4.3-4.7); pixels of queries that are not
    effective (p <= 0.5) are 0 (background). ``labels="splats"``: the texton with the largest
    composited splat weight (eq. 4.13), i.e. what the decoder sees; pixels no texton reaches
    are 0. ``num_queries``: E_s's queries resampled to that many (:mod:`neuraltex.query_grid`).
    ``labels="refined"``: the ``masks`` labels with every fine SLIC superpixel of the
    full-resolution image given its majority label (:func:`neuraltex.segmenters.refine_to_image`,
    4 superpixels per label), so boundaries follow image edges instead of E_s's stride 4.
    ``labels="guided"``: the upsampled masks relabelled pixel by pixel with each label's colour
    model (:func:`neuraltex.mask_refinement.colour_guided_labels`, with ``guide`` = (weight,
    reach), default its own); the queries that are not effective form one background label.
    ``tile``: how the picture is encoded (:func:`neuraltex.tiled_encode.encode_image`): whole
    (``"off"``), from overlapping tiles seen at twice the scale (``"on"``), or from tiles when
    the whole-picture run gives at least ``tile_from`` segments (``"auto"``; default
    :data:`neuraltex.tiled_segments.DENSE`, picked on the validation split).
    """
    import torch
    import torch.nn.functional as F

    from neuraltex.mask_refinement import REACH, WEIGHT, colour_guided_labels
    from neuraltex.model import DEFAULT_MODEL, load_model
    from neuraltex.segmenters import refine_to_image
    from neuraltex.splatting import opacity_maps
    from neuraltex.tiled_encode import encode_image, mask_labels
    from neuraltex.tiled_segments import DENSE, TILING

    checkpoint = checkpoint or DEFAULT_MODEL  # no --checkpoint: the shipped default model
    if not Path(checkpoint).exists():
        raise InputError(f"--method model: no model at {checkpoint}; pass --checkpoint PATH")
    if labels not in MODEL_LABELS:
        raise ValueError(f"labels must be one of {', '.join(MODEL_LABELS)}, got {labels!r}")
    if tile not in TILING:
        raise ValueError(f"tile must be one of {', '.join(TILING)}, got {tile!r}")
    model = load_model(checkpoint, device, num_queries=num_queries)
    weight, reach = guide or (WEIGHT, REACH)

    @torch.no_grad()
    def segment(image: np.ndarray) -> np.ndarray:
        _check_image(image)
        x = torch.from_numpy(np.ascontiguousarray(image, dtype=np.float32)).permute(2, 0, 1)
        H, W = x.shape[-2:]
        enc = encode_image(model, x[None].to(device), tile, dense_from=tile_from or DENSE)
        if labels != "splats":
            label = mask_labels(enc, (H, W))
            if labels == "guided":  # label 0: the queries that are not effective, together
                masks = F.interpolate(enc.masks, size=(H, W), mode="bilinear",
                                      align_corners=False)
                effective = enc.textons.p[0] > 0.5  # (n,)
                layers = torch.cat([masks[0, ~effective].sum(0, keepdim=True),
                                    masks[0, effective]])  # (1 + k, H, W)
                label = colour_guided_labels(layers, x, weight, reach)
            elif labels == "refined":
                coarse = label.cpu().numpy()
                n = len(np.unique(coarse))
                label = torch.from_numpy(refine_to_image(coarse, image.astype(np.float64), 4 * n))
        else:
            weights = opacity_maps(enc.textons, (H, W), cutoff=model.cutoff)[0]  # (K, H, W)
            label = weights.argmax(0) + 1
            label[weights.amax(0) < 0.05] = 0
        return label.cpu().numpy().astype(np.int64)

    return segment


@dataclass(frozen=True)
class Method:
    """A named method: ``build(value)`` gives a segmenter; ``param`` is what is tuned."""

    name: str
    build: Callable[[float], Segmenter]
    param: str
    default: float
    grid: tuple[float, ...]


# Defaults are the values picked by `python scripts/eval_textons.py --tune` on the
# validation split (see docs/baselines.md).
METHODS: dict[str, Method] = {m.name: m for m in [
    Method("grid", grid_segmenter, "cells", 12, (4, 6, 8, 10, 12, 14, 16, 20, 24)),
    Method("slic", slic_segmenter, "n_segments", 200, (25, 50, 75, 100, 150, 200, 300)),
    Method("felzenszwalb", felzenszwalb_segmenter, "scale", 10,
           (5, 10, 25, 50, 100, 200, 400, 800)),
    Method("kmeans", kmeans_segmenter, "k", 5, (2, 3, 4, 5, 6, 8)),
]}


def get_segmenter(name: str, value: float | None = None,
                  checkpoint: str | None = None, model_labels: str = "masks",
                  num_queries: int | None = None,
                  guide: tuple[float, float] | None = None,
                  tile: str = "off", tile_from: int | None = None) -> Segmenter:
    """Build method ``name`` (a key of ``METHODS`` or ``"model"``, with ``model_labels``,
    ``num_queries``, ``guide``, ``tile`` and ``tile_from`` as in :func:`model_segmenter`) at
    ``value``."""
    if name == "model":
        return model_segmenter(checkpoint or "", labels=model_labels, num_queries=num_queries,
                               guide=guide, tile=tile, tile_from=tile_from)
    if name not in METHODS:
        raise InputError(f"unknown method {name!r}; choose from "
                         f"{', '.join([*METHODS, 'model'])}")
    m = METHODS[name]
    return m.build(m.default if value is None else value)
