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

Which elements trade (:func:`compatible`, :func:`fitting_permutation`): alike in size, cut
by the same canvas sides, outlines that cover each other well once carried over
(:mod:`neuraltex.element_outline`), and on a ground of the same colour (a photograph's light
falls unevenly: a coin from a dark corner brings its dark margin); among those, a random
assignment that moves every element that has a partner.
"""

from __future__ import annotations

import math

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from neuraltex.element_outline import (
    Outlines,
    cover,
    outlines,
    shift_pixels,
    stretch,
)
from neuraltex.nn_utils import blur, labels_at
from neuraltex.texton_elements import SIZE_RATIO, ElementShapes, element_shapes

MARGIN = 2.0    # ground pixels around a footprint that move with its element
FEATHER = 0.7   # std (px) of the blend at a footprint's edge
ROUND = 1.5     # elongation below which an element is round (scaled, never turned)
FIT = 0.8       # least share of each outline's area that the other covers, mapped onto it
STRETCH = 1.4   # largest stretch of an outline onto the place it takes, in any direction
SHIFT = 6.0     # ... and largest miss, pixels
ELONGATION = 1.3  # largest ratio of the elongations of two elements that trade places
TURN = 30.0     # largest turn (degrees) of an elongated element onto its place
GROUND = 0.08   # largest difference (RGB, per channel) of two elements' grounds
RING_PIXELS = 8  # fewest margin pixels that make a ground
CHECKS = 4      # assignments solved again after pairs failed on the pixels


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


def compatible(shapes: ElementShapes, outline: Outlines, size_ratio: float = SIZE_RATIO,
               max_stretch: float = STRETCH, ground: np.ndarray | None = None) -> np.ndarray:
    """(E, E) bool: element e may take the place of element p (e != p, neither background):
    cut by the same canvas sides, areas within ``size_ratio``, elongations within
    ELONGATION, long axes within TURN (when either is elongated), carried onto p by the
    moment map an outline within ``max_stretch`` of p's in every direction and within SHIFT
    pixels of it (a large element's outline misses by many pixels where a small one's
    misses by one: the leaves of a tiled pattern, the strips of bark), covering FIT of p's
    area and of its own (:func:`neuraltex.element_outline.cover`: a brick and a half never
    takes a brick's place), and with ``ground`` (E, 3; :func:`ground_colours`) both with a
    ground of colours within GROUND of each other, or both without (a coin from the
    photograph's dark corner would arrive with its dark margin on a lighter ground)."""
    E = len(shapes.area)
    area = np.maximum(shapes.area, 1)
    ok = ((shapes.sides[:, None] == shapes.sides[None])
          & (np.maximum(area[:, None] / area[None], area[None] / area[:, None]) <= size_ratio)
          & (np.abs(np.log(shapes.elongation[:, None] / shapes.elongation[None]))
             <= math.log(ELONGATION))
          & ~shapes.background[:, None] & ~shapes.background[None] & ~np.eye(E, dtype=bool))
    round_ = np.maximum(shapes.elongation[:, None], shapes.elongation[None]) < ROUND
    turn = np.abs(shapes.angle[:, None] - shapes.angle[None]) % math.pi
    ok &= round_ | (np.minimum(turn, math.pi - turn) <= math.radians(TURN))
    if ground is not None:
        has = ~np.isnan(ground[:, 0])
        dist = np.nan_to_num(np.abs(ground[:, None] - ground[None]).max(-1), nan=np.inf)
        ok &= (has[:, None] == has[None]) & (~has[:, None] | (dist <= GROUND))
    e, p = np.nonzero(ok)
    s = stretch(outline, e, p, round_[e, p])  # (n, BINS)
    shift = shift_pixels(outline, s, p, round_[e, p])  # (n,)
    ok[e, p] = ((np.maximum(s, 1 / s).max(1) <= max_stretch) & (cover(s) >= FIT)
                & (shift <= SHIFT))
    return ok


def fitting_permutation(shapes: ElementShapes, place: np.ndarray, seed: int | None,
                        size_ratio: float = SIZE_RATIO, max_stretch: float = STRETCH,
                        outline: Outlines | None = None, ground: np.ndarray | None = None,
                        where: np.ndarray | None = None) -> np.ndarray:
    """(E,) int64: the place each element takes — a random permutation in which every
    element that has a :func:`compatible` partner is moved if it can be: the assignment of
    least total cost, uniform random costs on compatible pairs and a cost above any of them
    for staying. With ``where`` (H, W; element of each pixel) every pair the assignment
    picks is also checked on the pixels (:func:`overlap` at least FIT: the outlines are
    smoothed) and a failing pair is forbidden and the assignment solved again, CHECKS times
    at most; a cycle that still holds a failing pair then stays. place (H, W): element whose
    footprint each pixel is (:func:`footprints`). Deterministic per seed."""
    from scipy.optimize import linear_sum_assignment

    if outline is None:
        outline = outlines(place, shapes.centre, shapes.cov)
    ok = compatible(shapes, outline, size_ratio, max_stretch, ground)
    rng = np.random.default_rng(seed)
    cost = np.where(ok, rng.random(ok.shape), 1e6)  # incompatible: never chosen
    np.fill_diagonal(cost, 2.0)                      # staying: only without a partner
    pixels = None if where is None else element_pixels(where, len(cost))
    for _ in range(CHECKS):
        target = linear_sum_assignment(cost)[1].astype(np.int64)
        bad = [] if pixels is None else [
            e for e in np.nonzero(target != np.arange(len(target)))[0]
            if overlap(shapes, where, pixels, e, target[e]) < FIT]
        if not bad:
            return target
        cost[bad, target[bad]] = 1e6
    seen = target == np.arange(len(target))
    for start in np.nonzero(~seen)[0]:
        if seen[start]:
            continue
        cycle, e = [], start
        while not seen[e]:
            seen[e] = True
            cycle.append(e)
            e = target[e]
        if any(cost[a, target[a]] >= 1e6 for a in cycle):
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
    """How well element e fits the place of element p, on the pixels: the smaller of the
    share of p's pixels that e covers, mapped onto p (:func:`place_map`), and the share of
    e's pixels that land on p's. where (H, W): element of each pixel; pixels: (n, 2) x, y
    of each element's pixels."""
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
                   margin: float = MARGIN, feather: float = FEATHER,
                   plan_on: Tensor | None = None) -> tuple[Tensor, int, int]:
    """:func:`swap_elements`, and how many elements moved of those that are not
    background: -> (picture (3, H, W), moved, elements). ``plan_on`` (3, H, W): the picture
    whose ground colours choose the partners (default ``image``): the reconstruction, when
    ``image`` is the source photograph, so that the same places change hands as in the
    reconstruction's reshuffle. (On an exactly repeating picture, a tiled pattern, the
    partners an element finds are its own copies in the other tiles, whichever picture the
    plan is made on: drawn in the photograph such swaps change nothing.)"""
    H, W = image.shape[-2:]
    labels = labels_at(labels, (H, W))
    shapes, place, outline, target = plan(image if plan_on is None else plan_on, labels,
                                          groups, seed, size_ratio, margin)
    counts = int((target != np.arange(len(target))).sum()), int((~shapes.background).sum())
    grid, moved = source_grid(shapes, target, place)
    if not moved.any():
        return image.clone(), *counts
    grid = torch.from_numpy(grid).to(image)
    norm = torch.stack([(grid[..., 0] + 0.5) / W, (grid[..., 1] + 0.5) / H], -1) * 2 - 1
    out = F.grid_sample(image[None], norm[None], mode="bicubic", padding_mode="border",
                        align_corners=False)[0].clamp(0, 1)
    alpha = blur(torch.from_numpy(moved).to(image), feather)
    return alpha * out + (1 - alpha) * image, *counts


def ground_colours(image: Tensor, place: np.ndarray, where: np.ndarray,
                   background: np.ndarray) -> np.ndarray:
    """(E, 3) median colour of the ground in each element's footprint (its margin: the
    background pixels of its place), NaN for an element without one (stones of a wall touch
    each other). image (3, H, W); place, where (H, W)."""
    E = len(background)
    out = np.full((E, 3), np.nan)
    ring = background[where] & (place >= 0)
    if not ring.any():
        return out
    who = place[ring]
    rgb = image.detach().cpu().numpy()[:, ring].T  # (n, 3)
    order = np.argsort(who, kind="stable")
    starts = np.searchsorted(who[order], np.arange(E + 1))
    for k in np.nonzero(np.diff(starts) >= RING_PIXELS)[0]:
        out[k] = np.median(rgb[order[starts[k]:starts[k + 1]]], 0)
    return out


def plan(image: Tensor, labels: np.ndarray, groups: np.ndarray, seed: int | None,
         size_ratio: float = SIZE_RATIO, margin: float = MARGIN):
    """(element shapes, (H, W) footprints, their outlines, the place each element takes)
    for a picture (3, H, W), its labels (H, W) and groups (K,)."""
    shapes = element_shapes(labels, groups)
    where = groups[labels]
    place = footprints(where, shapes.background, margin)
    outline = outlines(place, shapes.centre, shapes.cov)
    ground = ground_colours(image, place, where, shapes.background)
    return shapes, place, outline, fitting_permutation(shapes, place, seed, size_ratio,
                                                       outline=outline, ground=ground,
                                                       where=where)
