"""Reconstruction v0: each output cluster becomes a translated copy of one input element.

For an output cluster C_o, the candidate input clusters are those its samples were matched to
(mu_s). Each candidate C_i is translated onto C_o by the mean offset of the matched pairs
(eq. 17) and scored by the shape distance (eq. 16): an optimal one-to-one matching of the
samples plus eps per unmatched sample, normalized by eps = 2 delta. The best candidate (eq. 15)
gives the element and its translation. Depth order and filtering by shape energy come with the
clustering step (issue 8); here elements are drawn in input z order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from cvt.sampling import Samples
from cvt.search import Matches


@dataclass(frozen=True)
class Placement:
    cluster: int  # output cluster id
    element: int  # input element (== input cluster id)
    dx: float
    dy: float
    energy: float  # shape distance d_C (eq. 16) of the chosen candidate
    z: int  # z-index of the input element


def shape_distance(p_out: np.ndarray, p_in: np.ndarray, eps: float) -> float:
    """Eq. 16 for already translated input samples. Shape: (A, 2), (B, 2) -> scalar."""
    if len(p_out) == 0 or len(p_in) == 0:
        return abs(len(p_out) - len(p_in)) * 1.0
    d = cdist(p_out, p_in)
    r, c = linear_sum_assignment(d)
    return float(d[r, c].sum()) / eps + abs(len(p_out) - len(p_in))


def reconstruct(out: Samples, inp: Samples, m: Matches, delta: float) -> list[Placement]:
    """Pick an input element and translation for every output cluster (eqs. 15-17)."""
    eps = 2 * delta
    o_pos, i_pos = out.pos.double().numpy(), inp.pos.double().numpy()
    o_cl, i_cl = out.cluster.numpy(), inp.cluster.numpy()
    mu = m.center.numpy()
    in_members = {int(c): np.flatnonzero(i_cl == c) for c in np.unique(i_cl)}
    placements = []
    for c in np.unique(o_cl):
        mem = np.flatnonzero(o_cl == c)
        src = i_cl[mu[mem]]  # input cluster each member is matched to
        best = None
        for ci in np.unique(src):
            pairs = mem[src == ci]
            shift = (o_pos[pairs] - i_pos[mu[pairs]]).mean(0)  # eq. 17
            d = shape_distance(o_pos[mem], i_pos[in_members[int(ci)]] + shift, eps)
            if best is None or d < best[0]:
                best = (d, int(ci), shift)
        d, ci, shift = best
        elem = int(inp.element[in_members[ci][0]])
        placements.append(Placement(int(c), elem, float(shift[0]), float(shift[1]), d,
                                    int(inp.z[in_members[ci][0]])))
    placements.sort(key=lambda p: (p.z, p.cluster))
    return placements


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise IoU of boxes (x0, y0, x1, y1). Shape: (P, 4), (Q, 4) -> (P, Q)."""
    lo = np.maximum(a[:, None, :2], b[None, :, :2])
    hi = np.minimum(a[:, None, 2:], b[None, :, 2:])
    inter = np.clip(hi - lo, 0, None).prod(-1)
    area_a = (a[:, 2:] - a[:, :2]).prod(-1)
    area_b = (b[:, 2:] - b[:, :2]).prod(-1)
    return inter / np.maximum(area_a[:, None] + area_b[None, :] - inter, 1e-12)


def merge_duplicates(placements: list[Placement], boxes: np.ndarray,
                     floor: float = 0.15) -> list[Placement]:
    """Drop placements that overlap a better one more than any two input elements overlap.

    A stopgap for v0: clusters cut at patch borders each rebuild a whole element, stacking
    near-copies. The clustering step (issue 8) fixes the cause. ``boxes`` (E, 4) are the input
    elements' bounding boxes.
    """
    if len(placements) < 2:
        return placements
    iou_in = box_iou(boxes, boxes)
    np.fill_diagonal(iou_in, 0)
    limit = max(floor, float(iou_in.max()) + 0.1)
    shift = np.array([[p.dx, p.dy, p.dx, p.dy] for p in placements])
    moved = boxes[[p.element for p in placements]] + shift  # (P, 4)
    iou = box_iou(moved, moved)
    kept = np.zeros(len(placements), dtype=bool)
    for k in np.argsort([p.energy for p in placements], kind="stable"):
        if not (iou[k, kept] > limit).any():
            kept[k] = True
    return [p for p, k in zip(placements, kept, strict=True) if k]


def upsample(placements: list[Placement], inp: Samples) -> Samples:
    """Next-level output: the finer input samples of each placed element, translated.

    Each placement becomes one whole cluster, so features are the input's (no broken
    clusters). ``inp`` must be the next level's input samples.
    """
    parts = []
    for k, pl in enumerate(placements):
        idx = torch.nonzero(inp.element == pl.element).flatten()
        s = inp.select(idx)
        shift = torch.tensor([pl.dx, pl.dy], dtype=s.pos.dtype)
        parts.append(s.with_(pos=s.pos + shift, cluster=torch.full_like(s.cluster, k),
                             source=idx))
    return Samples.concat(parts)
