"""Elements trade places in the picture: a reshuffle that keeps every object as sharp as the
reconstruction.

Decoding rearranged textons asks the tuned decoder G for layouts it was never tuned on, and
it answers with smudges: the ground where an object left keeps its halo, an object's detail
blurs on arrival (measured on coins: a reshuffle by decoding reads 3.1x the reconstruction's
patch-SWD, the same elements moved by this module 0.9x). So a texture file's reshuffle
renders the reconstruction R once, with the textons where they were tuned, and moves whole
elements (:mod:`neuraltex.texton_elements`) in the picture instead: element e, permuted onto
the place of element p (same shape class), is drawn over p's footprint through the affine map
that carries e's pixel moments onto p's,

    x_src = c_e + A^-1 (x - c_p),   A Sigma_e A^T = Sigma_p   (A = V_p diag(sqrt(l_p / l_e)) V_e^T)

(c: centroid, Sigma = V diag(l) V^T: pixel covariance; for two round elements A is the
isotropic scale sqrt(sqrt(det Sigma_p / det Sigma_e)), so nothing turns). Each footprint
takes a ``margin`` of the ground around it, so what arrives brings its own edge and the
ground next to it, and p's old edge is covered; there are no holes to fill, as every place
is filled by exactly one element. The background (grout, a backdrop) and elements that keep
their place stay as R draws them.
"""

from __future__ import annotations

import math

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from neuraltex.texton_elements import SIZE_RATIO, ElementShapes, element_shapes, permutation

MARGIN = 2.0    # ground pixels around a footprint that move with its element
FEATHER = 0.7   # std (px) of the blend at a footprint's edge
ROUND = 1.5     # elongation below which an element is round (scaled, never turned)
FIT = 0.8       # least share of each footprint that the other covers, mapped onto it


def place_map(src: np.ndarray, dst: np.ndarray, round_: bool) -> np.ndarray:
    """2 x 2 A with A src A^T = dst for pixel covariances src, dst (2, 2): the long axes
    matched without flipping (the rotation nearest the identity); round: isotropic."""
    if round_:
        return (np.linalg.det(dst) / np.linalg.det(src)) ** 0.25 * np.eye(2)
    ls, vs = np.linalg.eigh(src)
    ld, vd = np.linalg.eigh(dst)
    vd = vd * np.where((vd * vs).sum(0) < 0, -1.0, 1.0)  # column signs toward vs
    return vd @ np.diag(np.sqrt(ld / ls)) @ vs.T


def footprints(where: np.ndarray, background: np.ndarray, margin: float = MARGIN) -> np.ndarray:
    """(H, W) element whose place each pixel belongs to: the element's own pixels and the
    background pixels within ``margin`` of it (to the nearest element); -1 elsewhere.
    where (H, W) element of each pixel, background (E,) bool."""
    from scipy.ndimage import distance_transform_edt

    bg = background[where]
    out = np.where(bg, -1, where)
    if margin > 0 and bg.any() and not bg.all():
        dist, (iy, ix) = distance_transform_edt(bg, return_indices=True)
        near = bg & (dist <= margin)
        out[near] = where[iy[near], ix[near]]
    return out


def source_grid(shapes: ElementShapes, target: np.ndarray,
                place: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 2) pixel x, y each output pixel samples — the moment-matched map of the element
    that arrives at its place (``target[e]``: the place element e takes), identity elsewhere
    — and (H, W) bool: the pixels of places that changed hands."""
    from scipy.ndimage import find_objects

    H, W = place.shape
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    grid, moved = np.stack([xs, ys], -1), np.zeros((H, W), bool)
    arrives = np.arange(len(target))
    arrives[target] = np.arange(len(target))  # the element that arrives at place p
    boxes = find_objects(place + 1, max_label=len(target))  # each place's bounding slices
    for p in np.nonzero(arrives != np.arange(len(target)))[0]:
        if boxes[p] is None:
            continue
        e, box = arrives[p], boxes[p]
        m = place[box] == p
        round_ = max(shapes.elongation[e], shapes.elongation[p]) < ROUND
        Ai = np.linalg.inv(place_map(shapes.cov[e], shapes.cov[p], round_))
        g = grid[box]
        g[m] = shapes.centre[e] + (g[m] - shapes.centre[p]) @ Ai.T
        moved[box] |= m
    return grid, moved


def fitting_permutation(shapes: ElementShapes, where: np.ndarray, seed: int | None,
                        size_ratio: float = SIZE_RATIO, fit: float = FIT) -> np.ndarray:
    """(E,) int64: the place each element takes: the random permutation within each shape
    class that a texton reshuffle by elements draws for ``seed``
    (:func:`neuraltex.texton_elements.permutation`), but a cycle of it in which some element
    does not fit the place it takes — less than ``fit`` overlap, mapped onto it
    (:func:`overlap`): two bricks of one area but other proportions, or a brick and a pair of
    short ones, would break the mortar lines around them — stays where it was. where (H, W):
    element of each pixel."""
    target = permutation(shapes, seed, size_ratio)
    pixels = element_pixels(where, len(target))
    seen = target == np.arange(len(target))
    for start in np.nonzero(~seen)[0]:
        if seen[start]:
            continue
        cycle, e = [], start
        while not seen[e]:
            seen[e] = True
            cycle.append(e)
            e = target[e]
        if any(overlap(shapes, where, pixels, a, target[a]) < fit for a in cycle):
            target[cycle] = cycle
    return target


def element_pixels(where: np.ndarray, count: int) -> list[np.ndarray]:
    """(n_e, 2) x, y of the pixels of each of ``count`` elements in ``where`` (H, W)."""
    order = np.argsort(where.ravel(), kind="stable")  # pixels grouped by element
    starts = np.searchsorted(where.ravel()[order], np.arange(count + 1))
    return [np.stack(np.divmod(order[a:b], where.shape[1])[::-1], 1)
            for a, b in zip(starts[:-1], starts[1:], strict=True)]


def overlap(shapes: ElementShapes, where: np.ndarray, pixels: list[np.ndarray], e: int,
            p: int) -> float:
    """How well element e fits the place of element p: the smaller of the share of p's
    pixels that e covers, mapped onto p (:func:`place_map`), and the share of e's pixels
    that land on p's. where (H, W): element of each pixel; pixels: (n, 2) x, y of each
    element's pixels."""
    round_ = max(shapes.elongation[e], shapes.elongation[p]) < ROUND
    A = place_map(shapes.cov[e], shapes.cov[p], round_)
    shares = []
    for a, b, M in ((p, e, np.linalg.inv(A)), (e, p, A)):
        q = shapes.centre[b] + (pixels[a] - shapes.centre[a]) @ M.T
        qx, qy = np.rint(q[:, 0]).astype(np.int64), np.rint(q[:, 1]).astype(np.int64)
        inside = (qx >= 0) & (qx < where.shape[1]) & (qy >= 0) & (qy < where.shape[0])
        hit = np.zeros(len(qx), bool)
        hit[inside] = where[qy[inside], qx[inside]] == b
        shares.append(hit.mean() if len(hit) else 0.0)
    return float(min(shares))


def swap_elements(image: Tensor, labels: np.ndarray, groups: np.ndarray, *,
                  seed: int | None = None, size_ratio: float = SIZE_RATIO,
                  margin: float = MARGIN, feather: float = FEATHER) -> Tensor:
    """Elements trade places within their shape classes (:func:`fitting_permutation`) in
    ``image`` (3, H, W), the reconstruction of a texture file; labels (h, w) texton of each
    pixel at the fit's size (resampled to the image's), groups (K,) element of each texton.
    -> (3, H, W). Deterministic per seed."""
    return swap_and_count(image, labels, groups, seed=seed, size_ratio=size_ratio,
                          margin=margin, feather=feather)[0]


def swap_and_count(image: Tensor, labels: np.ndarray, groups: np.ndarray, *,
                   seed: int | None = None, size_ratio: float = SIZE_RATIO,
                   margin: float = MARGIN, feather: float = FEATHER
                   ) -> tuple[Tensor, int, int]:
    """:func:`swap_elements`, and how many elements moved of those that are not
    background: -> (picture (3, H, W), moved, elements)."""
    H, W = image.shape[-2:]
    if labels.shape != (H, W):
        lab = torch.from_numpy(np.ascontiguousarray(labels)).float()[None, None]
        labels = F.interpolate(lab, size=(H, W), mode="nearest")[0, 0].long().numpy()
    shapes, where, target = _plan(labels, groups, seed, size_ratio)
    counts = int((target != np.arange(len(target))).sum()), int((~shapes.background).sum())
    place = footprints(where, shapes.background, margin)
    grid, moved = source_grid(shapes, target, place)
    if not moved.any():
        return image.clone(), *counts
    grid = torch.from_numpy(grid).to(image)
    norm = torch.stack([(grid[..., 0] + 0.5) / W, (grid[..., 1] + 0.5) / H], -1) * 2 - 1
    out = F.grid_sample(image[None], norm[None], mode="bicubic", padding_mode="border",
                        align_corners=False)[0].clamp(0, 1)
    alpha = _blur(torch.from_numpy(moved).to(image), feather)
    return alpha * out + (1 - alpha) * image, *counts


def _plan(labels: np.ndarray, groups: np.ndarray, seed: int | None, size_ratio: float):
    """(element shapes, (H, W) element of each pixel, the place each element takes)."""
    shapes = element_shapes(labels, groups)
    where = groups[labels]
    return shapes, where, fitting_permutation(shapes, where, seed, size_ratio)


def _blur(mask: Tensor, sigma: float) -> Tensor:
    """(H, W) -> (H, W): a separable Gaussian blur (replicated edges); sigma 0: unchanged."""
    if sigma <= 0:
        return mask
    r = math.ceil(2 * sigma)
    x = torch.arange(-r, r + 1, dtype=mask.dtype)
    g = torch.exp(-x ** 2 / (2 * sigma ** 2))
    g = g / g.sum()
    a = F.conv2d(F.pad(mask[None, None], (r, r, 0, 0), mode="replicate"), g.view(1, 1, 1, -1))
    return F.conv2d(F.pad(a, (0, 0, r, r), mode="replicate"), g.view(1, 1, -1, 1))[0, 0]
