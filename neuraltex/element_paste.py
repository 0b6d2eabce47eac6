"""Placed elements bring the reconstruction's pixels: a synthesized texture as sharp as the
reconstruction.

Decoding arranged textons asks the tuned decoder G for layouts it was never tuned on, and it
answers with holes, halos and coloured specks (docs/synthesis.md, coins at 512 px: patch-SWD
18.1 decoded, 1.4 with this paste, 0.0 for the reconstruction itself). The reshuffle met
the same problem and solved it by moving elements in the picture
(:mod:`neuraltex.element_swap`); synthesis does the same with cvt's placements: each placed
element e, moved by (dx, dy) px, is drawn as the reconstruction R under its *footprint* (the
pixels of its textons, and the ground within ``margin`` px of them:
:func:`neuraltex.element_swap.footprints`), with a soft mask alpha_e = blur(footprint_e,
``feather``), over a ground picture B, in the input's draw order:

    out <- alpha_e(x - d_e) R(x - d_e) + (1 - alpha_e(x - d_e)) out(x),  out = B at first

(d_e rounded to whole pixels: no resampling blurs what is copied). Tileable: x - d_e is
taken modulo the output, so the paste wraps around like the arrangement. What is copied
("R" above and below) is the source picture at the texture's own size when the caller has it
(an image input, or ``neuraltex synthesize --source``), else the texture file's own
reconstruction: :func:`neuraltex.texton_synthesis.synthesize_texture` decides.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from neuraltex.element_swap import MARGIN, footprints
from neuraltex.nn_utils import blur, labels_at

REACH = 64  # px: gaps farther than this from any pasted pixel keep the decoded ground
# px: the cutouts' soft edge, and half the blur of the fill's joins. Half the reshuffle's:
# at 0.7 (joins blurred by 1.4 px) the many joins of a grown texture left smudged ghosts of
# cut spots (leopard) and lowered both measures of docs/synthesis.md (leopard patch-SWD x1000
# 0.46 -> 0.23, Gram 0.030 -> 0.016 at 0.35; burlwood 0.076 -> 0.046, 0.030 -> 0.027)
FEATHER = 0.35


@dataclass
class Cutout:
    """One element's pixels of the reconstruction: colour (3, h, w), alpha (h, w) and the
    top-left (y, x) of that box in the reconstruction."""

    rgb: Tensor
    alpha: Tensor
    corner: tuple[int, int]


def element_map(labels: np.ndarray, rows: np.ndarray, groups: list[list[int]],
                K: int) -> np.ndarray:
    """(H, W) element of each pixel (len(groups): not an element's: the background layer,
    textons that do not exist). labels (H, W) texton of each pixel, rows (E,) texton of each
    exemplar row, groups: positions into rows of each element's textons."""
    owner = np.full(K + 1, len(groups), np.int64)
    for g, members in enumerate(groups):
        owner[rows[members]] = g
    return owner[np.clip(labels, 0, K)]


def ground_margin(where: np.ndarray, background: int) -> float:
    """px of ground each element carries: the median distance from a ground pixel (``where``
    == ``background``) to the nearest element, at least ``MARGIN``. Elements on a ground
    (coins) then bring about their half of the gaps between them, so placements at the
    input's spacing meet on the input's own ground instead of on the gap fill; textures
    without a ground keep ``MARGIN`` (docs/synthesis.md: coins at 512 px, patch-SWD x1000
    3.17 at 2 px, 1.89 with this margin, about 6 px)."""
    from scipy.ndimage import distance_transform_edt

    ground = where == background
    if not ground.any() or ground.all():
        return MARGIN
    return max(MARGIN, float(np.median(distance_transform_edt(ground)[ground])))


def cutouts(recon: Tensor, labels: np.ndarray, rows: np.ndarray, groups: list[list[int]],
            K: int, margin: float | None = None,
            feather: float = FEATHER) -> list[Cutout | None]:
    """The :class:`Cutout` of each element (None: no pixel of its own) from the
    reconstruction ``recon`` (3, H, W) and its texton labels (h, w; resampled to H, W); the
    ground around each within ``margin`` px goes with it (None: :func:`ground_margin`)."""
    from scipy.ndimage import find_objects

    H, W = recon.shape[-2:]
    where = element_map(labels_at(labels, (H, W)), rows, groups, K)
    if margin is None:
        margin = ground_margin(where, len(groups))
    background = np.zeros(len(groups) + 1, bool)
    background[-1] = True
    place = footprints(where, background, margin)  # (H, W) element, -1: the ground
    pad = math.ceil(2 * feather) + 1  # the blurred mask reaches this far beyond a footprint
    out: list[Cutout | None] = []
    for g, box in enumerate(find_objects(place + 1, max_label=len(groups))):
        if box is None:
            out.append(None)
            continue
        y0, x0 = max(box[0].start - pad, 0), max(box[1].start - pad, 0)
        y1, x1 = min(box[0].stop + pad, H), min(box[1].stop + pad, W)
        mask = torch.from_numpy(place[y0:y1, x0:x1] == g).to(recon.dtype)
        out.append(Cutout(recon[:, y0:y1, x0:x1], blur(mask, feather).clamp(0, 1), (y0, x0)))
    return out


@dataclass
class Pasted:
    """What :func:`paste` drew: the picture (3, H, W), how much of each pixel the pastes
    cover (H, W) in [0, 1], and where the top paste of each pixel it mostly covers was copied
    from (H, W, 2) y, x in the reconstruction (-1: none)."""

    image: Tensor
    cover: Tensor
    source: np.ndarray


def paste(ground: Tensor, pieces: list[Cutout | None], placed: list[tuple[int, int, int]],
          tileable: bool = False) -> Pasted:
    """``ground`` (3, H, W) with each placement (element, dy, dx) (whole pixels, bottom to
    top) drawn over it from its cutout; ``tileable``: the pastes wrap around, otherwise what
    falls outside is cut."""
    out = ground.clone()
    H, W = out.shape[-2:]
    cover = torch.zeros(H, W, dtype=out.dtype)
    source = np.full((H, W, 2), -1, np.int64)
    for g, dy, dx in placed:
        c = pieces[g]
        if c is None:
            continue
        h, w = c.alpha.shape
        sy, sx = np.arange(h) + c.corner[0], np.arange(w) + c.corner[1]
        ys, xs = sy + dy, sx + dx
        if tileable:
            ys, xs = ys % H, xs % W
        iy, ix = (ys >= 0) & (ys < H), (xs >= 0) & (xs < W)
        if not (iy.any() and ix.any()):
            continue
        ty, tx = torch.from_numpy(ys[iy])[:, None], torch.from_numpy(xs[ix])[None]
        a = c.alpha[iy][:, ix]  # (h', w')
        out[:, ty, tx] = a * c.rgb[:, iy][:, :, ix] + (1 - a) * out[:, ty, tx]
        cover[ty, tx] = a + (1 - a) * cover[ty, tx]
        mine = (a > 0.5).numpy()
        yy, xx = np.broadcast_arrays(ys[iy][:, None], xs[ix][None])
        source[yy[mine], xx[mine]] = np.stack(np.broadcast_arrays(
            sy[iy][:, None], sx[ix][None]), -1)[mine]
    return Pasted(out, cover, source)


def fill_gaps(pasted: Pasted, recon: Tensor, ground: Tensor, tileable: bool = False,
              reach: int = REACH, feather: float = FEATHER,
              period: np.ndarray | None = None) -> Tensor:
    """The pasted picture with what the pastes leave uncovered (1 - cover) taken from the
    reconstruction around the nearest pasted pixel, as if that paste's cutout reached
    further: output pixel x, nearest pasted pixel q (copied from s(q)), copies s(q) + x - q
    (the ground and neighbours next to the element in the input), mirrored back into the
    reconstruction where it falls outside. Where q is more than ``reach`` px away,
    ``ground`` (3, H, W) stays. The joins between copies of different offsets are blurred by
    ``2 feather`` (around the wrap too when ``tileable``). ``period``: (2, 2) rows, whole-pixel
    (y, x) periods under which the reconstruction repeats exactly
    (:func:`neuraltex.raster_lattice.repeats_exactly`): copies whose offsets differ by one
    of them copy the same pixels, so they meet without a join, and a source pixel outside the
    reconstruction is brought back by whole periods instead of mirrored. -> (3, H, W)."""
    from scipy.ndimage import binary_dilation, distance_transform_edt

    H, W = pasted.cover.shape
    has = pasted.source[..., 0] >= 0
    if not has.any():
        return pasted.image
    p = reach if tileable else 0
    padded = np.pad(has, p, mode="wrap") if tileable else has
    dist, (iy, ix) = distance_transform_edt(~padded, return_indices=True)
    dist, iy, ix = (a[p:p + H, p:p + W] for a in (dist, iy - p, ix - p))  # q, unwrapped
    ys, xs = np.mgrid[0:H, 0:W]
    src = pasted.source[iy % H, ix % W] + np.stack([ys - iy, xs - ix], -1)  # (H, W, 2)
    h, w = recon.shape[-2:]
    inside = None if period is None else _into_picture(src, period, h, w)
    sy, sx = inside if inside is not None else (_mirror(src[..., 0], h), _mirror(src[..., 1], w))
    ok = dist <= reach
    fill = ground.clone()
    fill[:, torch.from_numpy(ok)] = recon[:, torch.from_numpy(sy[ok]), torch.from_numpy(sx[ok])]
    shift = np.where(ok[..., None], src - np.stack([ys, xs], -1), -(1 << 20))  # (H, W, 2)
    seam = np.zeros((H, W), bool)
    for axis in (0, 1):
        nxt = np.roll(shift, -1, axis)  # each pixel's next (wrapping)
        last = (slice(None), -1) if axis else (-1, slice(None))  # the last column (row)
        if tileable:  # its next lies one period on: the same copy's shift is one period less
            both = ok[last] & np.roll(ok, -1, axis)[last]
            nxt[last + (axis,)] -= np.where(both, (H, W)[axis], 0)
        step = (shift != nxt).any(-1)  # a join between copies of different offsets
        if period is not None:  # ... unless they differ by a period of the picture
            both = ok & np.roll(ok, -1, axis)
            step &= ~(both & _on_lattice(shift - nxt, period))
        if not tileable:  # the last row (column) has no next one
            step[last] = False
        seam |= step | np.roll(step, 1, axis)
    seam = torch.from_numpy(binary_dilation(seam) if not tileable else _dilate_wrap(seam))
    soft = blur(fill, feather * 2, "circular" if tileable else "replicate")
    fill = torch.where(seam, soft, fill)
    return pasted.image + (1 - pasted.cover) * (fill - ground)


def _into_picture(src: np.ndarray, period: np.ndarray, h: int,
                  w: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(y, x) indices (...,) of the positions ``src`` (..., 2) moved by whole periods (rows of
    ``period`` (2, 2)) into one cell that lies in the (h, w) picture; None when no cell near
    the origin does."""
    cell = np.array([[0, 0], period[0], period[1], period[0] + period[1]], float)  # corners
    for i, j in sorted(((i, j) for i in range(-3, 4) for j in range(-3, 4)),
                       key=lambda ij: abs(ij[0]) + abs(ij[1])):
        t = i * period[0] + j * period[1]
        c = cell + t
        if c[:, 0].min() >= 0 and c[:, 0].max() <= h and c[:, 1].min() >= 0 and c[:, 1].max() <= w:
            break
    else:
        return None
    k = np.floor(src @ np.linalg.inv(period.astype(float)) + 1e-9)  # whole periods to remove
    rep = np.rint(src - k @ period + t).astype(np.int64)
    return np.clip(rep[..., 0], 0, h - 1), np.clip(rep[..., 1], 0, w - 1)


def _on_lattice(d: np.ndarray, period: np.ndarray) -> np.ndarray:
    """Whether each offset (..., 2) is a whole combination of the rows of ``period`` (2, 2)."""
    c = d @ np.linalg.inv(period.astype(float))  # (..., 2) lattice coordinates
    return (np.abs(c - np.rint(c)) < 1e-6).all(-1)


def _mirror(i: np.ndarray, n: int) -> np.ndarray:
    """Indices reflected into [0, n) (..., 1, 0, 0, 1, ..., n - 1, n - 1, n - 2, ...)."""
    i = np.mod(i, 2 * n)
    return np.where(i < n, i, 2 * n - 1 - i)


def _dilate_wrap(mask: np.ndarray) -> np.ndarray:
    """A 3 x 3 cross dilation of an (H, W) bool mask on the torus."""
    out = mask.copy()
    for axis in (0, 1):
        out |= np.roll(mask, 1, axis) | np.roll(mask, -1, axis)
    return out


def pixel_placements(placements: list[tuple[int, float, float]], rank: np.ndarray,
                     short: int) -> list[tuple[int, int, int]]:
    """cvt's placements (element, dx, dy) in normalized units -> (element, dy, dx) in whole
    pixels at ``short`` px per unit, sorted bottom to top by ``rank`` (E,) of each element
    (ties: placement order)."""
    order = np.lexsort((np.arange(len(placements)), rank[[p[0] for p in placements]]))
    return [(int(placements[i][0]), int(round(placements[i][2] * short)),
             int(round(placements[i][1] * short))) for i in order]


def element_rank(order: np.ndarray, rows: np.ndarray, groups: list[list[int]]) -> np.ndarray:
    """(E,) draw rank of each element: the lowest draw order of its textons. order (K,)."""
    return np.array([order[rows[g]].min() for g in groups])
