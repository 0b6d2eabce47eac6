"""Elements: the textons that together make one object of a texture (a coin, a brick, a stone).

The segments that give a sharp fit (:mod:`neuraltex.segmenters`, up to 400 per image) cut an
object into several textons, and trading appearance features between such fragments (seed
003, 4.4.1) mixes pieces of different objects: half a coin on another coin's rim. So a fit
also groups its textons into *elements* — Felzenszwalb segments of the image at ``COARSER``
times the scale of the fit's segments, every texton joining the element that holds most of
its pixels; concentric textons and *hugging* elements (a coin's rim arcs, a rosette's ring:
almost all their pixels within a quarter radius of a larger element) join too; an element
as large as a background (BACKGROUND_SHARE of the canvas) is parted again by the segments at
``FINER`` times the fit's scale, so the stones of gravel or a wall, one mass at the coarse
scale, are elements of their own while a true backdrop stays whole; and a *mosaic* — a union
of textons that are compact on their own but not together, stones alike in colour — is parted
into its textons.

A reshuffle moves whole elements: element e takes the place of element pi(e), pi a random
permutation within a *shape class* (area within a factor ``SIZE_RATIO``, elongation within a
factor 2, for elongated elements the long axis within 45 degrees). ``neuraltex reshuffle``
does it in the picture (:mod:`neuraltex.element_swap`: each element drawn from the
reconstruction onto its new place); :func:`reshuffle_elements` gives the textons of the same
reshuffle — every texton moved by the offset between the two elements' centroids, features
and detail sprites with it, the background's textons trading features within their kinds —
for a decoder to render (the previous way, and what ``scripts/eval_real.py`` compares with).
The ratio is tight (1.1) because objects of other sizes bring seams: measured on coins, the
reshuffle in the picture reads 0.93x the reconstruction's patch-SWD at 1.1 and 1.6x at 1.25
(a dark-rimmed coin scaled onto a clean one's place).

Elements cut by the canvas border trade places only with elements cut by the same sides (moved
inside they would show their cut edge). Background elements (grout, a backdrop, the bark
between cracks) stay.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import torch
from torch import Tensor

from neuraltex.texton_kinds import BACKGROUND_SHARE, texton_area
from neuraltex.textons import Textons

COARSER = 4.0       # elements: Felzenszwalb at this many times the fit's scale ...
FINER = 2.0         # ... and inside a background-sized element at this many times
CONCENTRIC = 0.5    # Mahalanobis distance within which a smaller texton is concentric
SIZE_RATIO = 1.1     # largest area ratio of two elements that trade places
ELONGATED = 1.5      # sqrt(l1 / l2) above which an element has a direction
HUG_REACH = 0.25     # a hugging element lies within this many radii of a larger one ...
HUG_SHARE = 0.8      # ... with this share of its pixels
LOOSE = 0.7          # solidity below which a union of compact textons is a mosaic ...
MEMBER = 0.75        # ... when the median solidity of its textons is at least this


def group_textons(image: Tensor, labels: np.ndarray, textons: Textons | None = None,
                  coarser: float = COARSER) -> np.ndarray:
    """Element of each texton: image (3, H, W) in [0, 1], labels (H, W) texton of each pixel
    -> (K,) int64 element ids 0..E-1. With the ``textons`` (batch size 1), concentric textons
    also join one element: the rim around a coin or the halo around a dot is a segment of
    its own at any scale, but its Gaussian sits on the centre of the one it surrounds."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from neuraltex.segmenters import MAX_SEGMENTS, felzenszwalb_labels

    K = int(labels.max()) + 1
    arr = (image.detach().cpu().permute(1, 2, 0).clamp(0, 1).numpy() * 255).astype(np.uint8)
    coarse = felzenszwalb_labels(arr, MAX_SEGMENTS, coarser=coarser)
    joint = np.zeros((K, int(coarse.max()) + 1), np.int64)
    np.add.at(joint, (labels.ravel(), coarse.ravel()), 1)
    src, dst = np.arange(K), K + joint.argmax(1)                 # texton -- its segment
    if textons is not None:
        i, j = _concentric(textons)
        src, dst = np.concatenate([src, i]), np.concatenate([dst, j])
    n = K + joint.shape[1]
    graph = coo_matrix((np.ones(len(src)), (src, dst)), shape=(n, n))
    _, component = connected_components(graph, directed=False)
    groups = np.unique(component[:K], return_inverse=True)[1].ravel().astype(np.int64)
    i, j = _hugging(groups[labels])
    graph = coo_matrix((np.ones(len(i)), (i, j)), shape=(groups.max() + 1,) * 2)
    groups = connected_components(graph, directed=False)[1][groups].astype(np.int64)
    groups = _finer_in_background(groups, labels,
                                  lambda: felzenszwalb_labels(arr, MAX_SEGMENTS, coarser=FINER))
    return _parted_mosaics(groups, labels)


def _finer_in_background(groups: np.ndarray, labels: np.ndarray,
                         segments: Callable[[], np.ndarray]) -> np.ndarray:
    """Elements (K,) of textons (labels (H, W)) where each element of at least
    BACKGROUND_SHARE of the image is parted by the finer ``segments()`` (H, W; only computed
    when there is such an element) inside it (every
    texton joining the one holding most of its pixels): at the coarse scale the stones of
    gravel or of a wall merge into one mass that would stay put as background, at the fit's
    own scale they are stones; a true backdrop (the ground under coins, the mortar of
    bricks) keeps pieces that are background themselves or alike. -> (K,) int64."""
    K = len(groups)
    area = np.bincount(groups[labels].ravel(), minlength=int(groups.max()) + 1)
    big = area >= BACKGROUND_SHARE * labels.size
    if not big.any():
        return groups
    fine = segments()
    joint = np.zeros((K, int(fine.max()) + 1), np.int64)
    np.add.at(joint, (labels.ravel(), fine.ravel()), 1)
    key = np.where(big[groups], groups.max() + 1 + joint.argmax(1), groups)
    return np.unique(key, return_inverse=True)[1].ravel().astype(np.int64)


def solidity(regions: np.ndarray) -> np.ndarray:
    """(R,) filled area over convex-hull area of each region of an (H, W) map of ids
    0..R-1 (holes filled: a ring counts as the disc it encloses); 1 for an absent id."""
    from skimage.measure import regionprops

    out = np.ones(int(regions.max()) + 1)
    for r in regionprops(regions + 1):
        out[r.label - 1] = r.area_filled / r.area_convex
    return out


def _parted_mosaics(groups: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Elements (K,) of textons (labels (H, W)) with every *mosaic* parted into its textons:
    an element of at least 3 textons, not background-sized, whose union is not compact
    (solidity below LOOSE) while its textons are (median solidity MEMBER or more) — stones of
    a wall that the coarse scale merged because they look alike. A coin (a compact union of
    fragments) and a rosette (ring arcs, not compact themselves) stay whole. -> (K,) int64."""
    K = len(groups)
    n = np.bincount(groups)
    area = np.bincount(groups[labels].ravel(), minlength=len(n))
    member = solidity(labels)[:K]
    typical = np.array([np.median(member[groups == e]) for e in range(len(n))])
    mosaic = ((n >= 3) & (area < BACKGROUND_SHARE * labels.size)
              & (solidity(groups[labels]) < LOOSE) & (typical >= MEMBER))
    if not mosaic.any():
        return groups
    key = np.where(mosaic[groups], groups.max() + 1 + np.arange(K), groups)
    return np.unique(key, return_inverse=True)[1].ravel().astype(np.int64)


def _hugging(elements: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (i, j): element i lies almost whole (HUG_SHARE of its pixels) within HUG_REACH
    times the radius of the larger element j of the (H, W) element map — a coin's rim arc
    around its face, a rosette's ring around its centre, a halo (background elements
    excluded). Each i joins the j that holds most of it."""
    from scipy.ndimage import distance_transform_edt, find_objects

    E = int(elements.max()) + 1
    H, W = elements.shape
    boxes = find_objects(elements + 1)                              # bounding slices
    area = np.bincount(elements.ravel(), minlength=E)
    big = area >= BACKGROUND_SHARE * elements.size
    best, share = np.full(E, -1), np.zeros(E)
    for j in np.argsort(-area):
        if big[j] or area[j] < 16:
            continue
        reach = HUG_REACH * math.sqrt(area[j] / math.pi)
        m = math.ceil(reach) + 1                                    # window: j's box + reach
        ys, xs = boxes[j]
        win = elements[max(ys.start - m, 0):min(ys.stop + m, H),
                       max(xs.start - m, 0):min(xs.stop + m, W)]
        near = distance_transform_edt(win != j) <= reach
        s = np.bincount(win[near], minlength=E) / np.maximum(area, 1)
        take = (s >= HUG_SHARE) & (s > share) & (area < area[j]) & ~big
        best[take], share[take] = j, s[take]
    i = np.nonzero(best >= 0)[0]
    return i, best[i]


def _concentric(textons: Textons) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (i, j) of textons whose centres lie within Mahalanobis distance CONCENTRIC of
    each other in both Gaussians' metrics (j the larger, not the background)."""
    mu, cov = textons.mu[0].detach().cpu().double(), textons.cov[0].detach().cpu().double()
    area = texton_area(textons)[0].detach().cpu().double()
    canvas = textons.canvas[0] * textons.canvas[1]
    d = mu[:, None] - mu[None]                                   # (K, K, 2): mu_i - mu_j
    m2 = (d.unsqueeze(-2) @ torch.linalg.inv(cov)[None] @ d.unsqueeze(-1))[..., 0, 0]  # in j's
    ok = ((torch.maximum(m2, m2.T) < CONCENTRIC ** 2) & (area[None] > area[:, None])
          & (area < BACKGROUND_SHARE * canvas)[None])
    i, j = np.nonzero(ok.numpy())
    return i, j


@dataclass
class ElementShapes:
    area: np.ndarray        # (E,) pixels
    centre: np.ndarray      # (E, 2) x, y in pixels
    elongation: np.ndarray  # (E,) sqrt of the ratio of the pixel covariance's eigenvalues
    angle: np.ndarray       # (E,) direction of the long axis, [0, pi)
    sides: np.ndarray       # (E,) int64 bit mask of the canvas sides it touches (1 2 4 8: l r t b)
    background: np.ndarray  # (E,) bool: covers at least BACKGROUND_SHARE of the canvas
    cov: np.ndarray         # (E, 2, 2) covariance of its pixels' x, y (+ 1/12: a pixel's own)


def element_shapes(labels: np.ndarray, groups: np.ndarray,
                   background: float = BACKGROUND_SHARE) -> ElementShapes:
    """Shape of each element from the pixels of its textons (labels (H, W), groups (K,))."""
    H, W = labels.shape
    el = groups[labels].ravel()
    E = int(groups.max()) + 1
    ys, xs = np.divmod(np.arange(H * W), W)
    area = np.bincount(el, minlength=E).astype(float)
    n = np.maximum(area, 1)
    mx, my = np.bincount(el, xs, E) / n, np.bincount(el, ys, E) / n
    dx, dy = xs - mx[el], ys - my[el]
    cxx, cyy, cxy = (np.bincount(el, w, E) / n for w in (dx * dx, dy * dy, dx * dy))
    half = np.sqrt(((cxx - cyy) / 2) ** 2 + cxy ** 2)
    l1, l2 = (cxx + cyy) / 2 + half, (cxx + cyy) / 2 - half
    elongation = np.sqrt((l1 + 1 / 12) / (np.maximum(l2, 0) + 1 / 12))
    angle = (0.5 * np.arctan2(2 * cxy, cxx - cyy)) % math.pi
    sides = np.zeros(E, np.int64)
    for bit, line in enumerate((labels[:, 0], labels[:, -1], labels[0], labels[-1])):
        sides[np.unique(groups[line])] |= 1 << bit
    background = area >= background * H * W
    cov = np.stack([np.stack([cxx, cxy], -1), np.stack([cxy, cyy], -1)], -2) + np.eye(2) / 12
    return ElementShapes(area, np.stack([mx, my], 1), elongation, angle, sides, background, cov)


def shape_classes(shapes: ElementShapes, size_ratio: float = SIZE_RATIO) -> np.ndarray:
    """(E,) int64 class of each element (-1: the background stays); elements of one class
    trade places: alike in area, elongation, direction and the canvas sides that cut them."""
    e = np.floor(np.log(shapes.elongation) / math.log(2))
    d = np.where(shapes.elongation > ELONGATED, np.floor(shapes.angle / (math.pi / 4)) % 4, -1)
    _, kind = np.unique(np.stack([e, d, shapes.sides], 1), axis=0, return_inverse=True)
    # within a kind, runs of areas sorted ascending, each within size_ratio of its smallest
    # (fixed log-area bins would part two coins of 1.01x the area at a bin edge)
    area = np.maximum(shapes.area, 1)
    classes, start, last = np.empty(len(area), np.int64), np.inf, -1
    for n, i in enumerate(np.lexsort((area, kind.ravel()))):
        if kind.ravel()[i] != last or area[i] > start * size_ratio:
            start, last, c = area[i], kind.ravel()[i], n
        classes[i] = c
    return np.where(shapes.background, -1, np.unique(classes, return_inverse=True)[1].ravel())


def move_elements(textons: Textons, labels: np.ndarray, groups: np.ndarray, *,
                  seed: int | None = None, size_ratio: float = SIZE_RATIO) -> Textons:
    """Each element takes the place of another of its shape class; its textons (batch size
    1) move with all their features. Deterministic per seed."""
    return _move(textons, element_shapes(labels, groups), groups, min(labels.shape), seed,
                 size_ratio)


def _move(textons: Textons, shapes: ElementShapes, groups: np.ndarray, short: int,
          seed: int | None, size_ratio: float) -> Textons:
    """:func:`move_elements` with the elements' shapes at hand (``short``: pixels per unit)."""
    target = permutation(shapes, seed, size_ratio)
    shift = (shapes.centre[target] - shapes.centre)[groups] / short  # (K, 2)
    return replace(textons, mu=textons.mu + torch.from_numpy(shift).to(textons.mu)[None])


def permutation(shapes: ElementShapes, seed: int | None,
                size_ratio: float = SIZE_RATIO) -> np.ndarray:
    """(E,) int64: the element whose place each element takes, a random permutation within
    each shape class (:func:`shape_classes`); the background stays."""
    classes = shape_classes(shapes, size_ratio)
    rng = np.random.default_rng(seed)
    target = np.arange(len(classes))
    for c in np.unique(classes[classes >= 0]):
        idx = np.nonzero(classes == c)[0]
        target[idx] = idx[rng.permutation(len(idx))]
    return target


def swapped_layout(image: Tensor, labels: np.ndarray, groups: np.ndarray, textons: Textons,
                   seed: int) -> tuple[Textons, Tensor, Tensor]:
    """A layout in which elements trade places as in a reshuffle, by whole pixels, and what it
    must look like: -> (the textons moved, the target (3, H, W): ``image`` with every moved
    element's pixels pasted at its new place, its mask (H, W) float: 0 where an element left
    and none arrived, a place whose look nothing in the image tells). Fitting detail to such
    layouts too keeps the ground's detail from holding the halo of the object that was there."""
    H, W = labels.shape
    shapes = element_shapes(labels, groups)
    target = permutation(shapes, seed)
    d = np.round(shapes.centre[target] - shapes.centre).astype(np.int64)   # (E, 2) x, y px
    where = groups[labels]                                                 # (H, W) element
    out, known = image.clone(), np.ones((H, W), bool)
    moved = np.nonzero(target != np.arange(len(target)))[0]
    known[np.isin(where, moved)] = False
    for e in moved:
        ys, xs = np.nonzero(where == e)
        ny, nx = ys + d[e, 1], xs + d[e, 0]
        ok = (ny >= 0) & (ny < H) & (nx >= 0) & (nx < W)
        out[:, ny[ok], nx[ok]] = image[:, ys[ok], xs[ok]]
        known[ny[ok], nx[ok]] = True
    shift = torch.from_numpy(d[groups] / min(H, W)).to(textons.mu)       # (K, 2)
    return (replace(textons, mu=textons.mu + shift[None]), out,
            torch.from_numpy(known).to(image.dtype))


def reshuffle_elements(textons: Textons, labels: np.ndarray, groups: np.ndarray, *,
                       channels: int | None = None, seed: int | None = None,
                       size_ratio: float = SIZE_RATIO) -> Textons:
    """Reshuffle a fitted texture (batch size 1) by elements: objects trade places
    (:func:`move_elements`), and the textons of the background elements (grout, ground,
    bark: stuff rather than objects) trade features with textons of their kind
    (:func:`neuraltex.texton_kinds.texton_kinds` on the first ``channels`` of f, area within
    the same ``size_ratio``), as in the seed's reshuffle. The ground is drawn behind the
    objects."""
    from neuraltex.reshuffle import reshuffle
    from neuraltex.texton_kinds import texton_kinds

    shapes = element_shapes(labels, groups)
    stuff = torch.from_numpy(shapes.background[groups]).to(textons.device)[None]  # (1, K)
    kinds = texton_kinds(textons, channels=channels, size_ratio=size_ratio).to(textons.device)
    moved = _move(textons, shapes, groups, min(labels.shape), seed, size_ratio)
    # a moved object lands on ground it did not cover before: draw the ground behind it
    key = (~stuff).long() * textons.num_textons + textons.order
    order = torch.argsort(torch.argsort(key, dim=1), dim=1)
    return reshuffle(replace(moved, order=order), seed=seed, kinds=torch.where(stuff, kinds, -1))
