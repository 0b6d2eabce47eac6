"""Initial output graph: random input patches copied onto a grid (seed 001 sec. 4.3.2, cvt's
patch init), with the edges inside each patch, clipped to the output domain."""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

from cvt.curves.graph import CurveGraph


def box_inside(box, inside: Callable[[torch.Tensor], torch.Tensor] | None = None):
    """Domain predicate: inside the box (x0, y0, x1, y1) and, if given, ``inside``."""
    x0, y0, x1, y1 = box

    def test(p: torch.Tensor) -> torch.Tensor:  # (N, 2) -> (N,) bool
        ok = (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)
        return ok & inside(p) if inside is not None else ok

    return test


def patch_init(inp: CurveGraph, in_box, out_box, patch: float, inside, gen: torch.Generator
               ) -> CurveGraph:
    """Copy random input patches of side ``patch`` onto a grid covering ``out_box``."""
    ix0, iy0, ix1, iy1 = in_box
    ox0, oy0, ox1, oy1 = out_box
    pw, ph = min(patch, ix1 - ix0), min(patch, iy1 - iy0)
    parts = []
    for gy in range(math.ceil((oy1 - oy0) / ph)):
        for gx in range(math.ceil((ox1 - ox0) / pw)):
            u = torch.rand(2, generator=gen, dtype=torch.float64)
            sx = ix0 + float(u[0]) * (ix1 - ix0 - pw)
            sy = iy0 + float(u[1]) * (iy1 - iy0 - ph)
            idx = torch.nonzero((inp.pos[:, 0] >= sx) & (inp.pos[:, 0] < sx + pw)
                                & (inp.pos[:, 1] >= sy) & (inp.pos[:, 1] < sy + ph)).flatten()
            shift = torch.tensor([ox0 + gx * pw - sx, oy0 + gy * ph - sy], dtype=torch.float64)
            g = inp.select(idx)
            parts.append(g.with_(pos=g.pos + shift, source=idx))
    out = CurveGraph.empty(inp.styles)
    for g in parts:
        out = out.cat(g)
    return out.select(torch.nonzero(inside(out.pos)).flatten())
