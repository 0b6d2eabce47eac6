"""Initial output graph: random input patches copied onto a grid (seed 001 sec. 4.3.2, cvt's
patch init), with the edges inside each patch, clipped to the output domain."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import torch

from cvt.curves.graph import CurveGraph


def box_inside(box, inside: Callable[[torch.Tensor], torch.Tensor] | None = None):
    """Domain predicate: inside the box (x0, y0, x1, y1) and, if given, ``inside``."""
    x0, y0, x1, y1 = box

    def test(p: torch.Tensor) -> torch.Tensor:  # (N, 2) -> (N,) bool
        ok = (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)
        return ok & inside(p) if inside is not None else ok

    return test


def _mismatch(placed: np.ndarray, ctx: np.ndarray, scale: float) -> float:
    """Symmetric mean nearest-neighbour distance of two point sets (capped at ``scale``)."""
    from scipy.spatial import cKDTree

    if len(placed) == 0 and len(ctx) == 0:
        return 0.0
    if len(placed) == 0 or len(ctx) == 0:
        return scale
    a = cKDTree(placed).query(ctx, distance_upper_bound=scale)[0]
    b = cKDTree(ctx).query(placed, distance_upper_bound=scale)[0]
    return float(np.minimum(np.r_[a, b], scale).mean())


def _choose(inp_pos: np.ndarray, placed: np.ndarray, cell, patch, band: float,
            starts: np.ndarray, origin) -> int:
    """The start whose exemplar surroundings (a ``band`` left of and above the patch, inside
    the output from ``origin`` on) best match the samples already placed there (sec. 4.3.2).
    ``starts`` (K, 2)."""
    cx0, cy0 = cell
    lo = np.maximum([cx0 - band, cy0 - band], origin)
    hi = np.array([cx0 + patch[0], cy0 + patch[1]])
    ring = (placed >= lo).all(1) & (placed < hi).all(1) & \
        ~((placed[:, 0] >= cx0) & (placed[:, 1] >= cy0))
    ref = placed[ring]
    if len(ref) == 0:
        return 0
    cost = []
    for sx, sy in starts:
        q = inp_pos + np.array([cx0 - sx, cy0 - sy])
        inside = (q >= lo).all(1) & (q < hi).all(1) & ~((q[:, 0] >= cx0) & (q[:, 1] >= cy0))
        cost.append(_mismatch(ref, q[inside], band))
    return int(np.argmin(cost))


def patch_init(inp: CurveGraph, in_box, out_box, patch: float, inside, gen: torch.Generator,
               candidates: int = 1) -> CurveGraph:
    """Copy input patches of side ``patch`` onto a grid covering ``out_box``: random ones
    (``candidates`` = 1), or of ``candidates`` random ones the one whose exemplar
    surroundings best continue the patches already placed to its left and above (seed 001
    sec. 4.3.2, patches chosen by similarity in the overlap)."""
    ix0, iy0, ix1, iy1 = in_box
    ox0, oy0, ox1, oy1 = out_box
    pw, ph = min(patch, ix1 - ix0), min(patch, iy1 - iy0)
    in_pos = inp.pos.numpy()
    out = CurveGraph.empty(inp.styles)
    for gy in range(math.ceil((oy1 - oy0) / ph)):
        for gx in range(math.ceil((ox1 - ox0) / pw)):
            u = torch.rand(candidates, 2, generator=gen, dtype=torch.float64).numpy()
            starts = np.c_[ix0 + u[:, 0] * (ix1 - ix0 - pw), iy0 + u[:, 1] * (iy1 - iy0 - ph)]
            cell = (ox0 + gx * pw, oy0 + gy * ph)
            k = _choose(in_pos, out.pos.numpy(), cell, (pw, ph), 0.5 * patch,
                        starts, (ox0, oy0)) if candidates > 1 else 0
            sx, sy = starts[k]
            idx = torch.nonzero((inp.pos[:, 0] >= sx) & (inp.pos[:, 0] < sx + pw)
                                & (inp.pos[:, 1] >= sy) & (inp.pos[:, 1] < sy + ph)).flatten()
            shift = torch.tensor([cell[0] - sx, cell[1] - sy], dtype=torch.float64)
            g = inp.select(idx)
            out = out.cat(g.with_(pos=g.pos + shift, source=idx))
    return out.select(torch.nonzero(inside(out.pos)).flatten())
