"""Initial output samples (seed 000 sec. 6.2).

Patch init: tile the output with square cells of size 2r and fill each with the samples of a
random input patch of the same size. Samples of one input cluster inside one copied patch share
a fresh cluster id; clusters cut at the patch border get their features recomputed.
Random init (option): samples at random places copying random input samples, one cluster each.
"""

from __future__ import annotations

import math

import torch

from cvt.sampling import Samples
from cvt.shape_context import shape_contexts


def patch_init(inp: Samples, in_box, out_box, patch: float, gen: torch.Generator) -> Samples:
    """Copy random input patches of side ``patch`` onto a grid covering ``out_box``.

    Boxes are (x0, y0, x1, y1) in user units.
    """
    ix0, iy0, ix1, iy1 = in_box
    ox0, oy0, ox1, oy1 = out_box
    pw, ph = min(patch, ix1 - ix0), min(patch, iy1 - iy0)
    nx, ny = math.ceil((ox1 - ox0) / pw), math.ceil((oy1 - oy0) / ph)
    parts, next_id = [], 0
    for gy in range(ny):
        for gx in range(nx):
            u = torch.rand(2, generator=gen, dtype=torch.float64)
            sx = ix0 + float(u[0]) * (ix1 - ix0 - pw)
            sy = iy0 + float(u[1]) * (iy1 - iy0 - ph)
            inside = ((inp.pos[:, 0] >= sx) & (inp.pos[:, 0] < sx + pw)
                      & (inp.pos[:, 1] >= sy) & (inp.pos[:, 1] < sy + ph))
            idx = torch.nonzero(inside).flatten()
            if idx.numel() == 0:
                continue
            shift = torch.tensor([ox0 + gx * pw - sx, oy0 + gy * ph - sy], dtype=inp.pos.dtype)
            s = inp.select(idx)
            _, local = torch.unique(s.cluster, return_inverse=True)
            parts.append(s.with_(pos=s.pos + shift, cluster=local + next_id, source=idx))
            next_id += int(local.max()) + 1
    if not parts:  # a sparse exemplar whose patches all came up empty
        return random_init(inp, in_box, out_box, gen)
    out = Samples.concat(parts)
    keep = ((out.pos[:, 0] <= ox1) & (out.pos[:, 1] <= oy1))
    out = out.select(torch.nonzero(keep).flatten())
    if len(out) == 0:  # output smaller than one patch's first samples
        return random_init(inp, in_box, out_box, gen)
    return _refresh_cut_features(out, inp)


def _refresh_cut_features(out: Samples, inp: Samples) -> Samples:
    """Recompute shape contexts of clusters that lost samples at a patch border."""
    full = torch.bincount(inp.cluster)[inp.cluster[out.source]]  # (N,) input cluster sizes
    have = torch.bincount(out.cluster)[out.cluster]  # (N,) output cluster sizes
    cut = have < full
    if cut.any():
        idx = torch.nonzero(cut).flatten()
        feat = out.feat.clone()
        feat[idx] = shape_contexts(out.pos[idx], out.cluster[idx])
        out = out.with_(feat=feat)
    return out


def random_init(inp: Samples, in_box, out_box, gen: torch.Generator) -> Samples:
    """As many samples per area as the input, at uniform random places, one cluster each."""
    ix0, iy0, ix1, iy1 = in_box
    ox0, oy0, ox1, oy1 = out_box
    n = max(1, round(len(inp) * (ox1 - ox0) * (oy1 - oy0) / ((ix1 - ix0) * (iy1 - iy0))))
    src = torch.randint(len(inp), (n,), generator=gen)
    u = torch.rand(n, 2, generator=gen, dtype=torch.float64).to(inp.pos.dtype)
    pos = torch.stack([ox0 + u[:, 0] * (ox1 - ox0), oy0 + u[:, 1] * (oy1 - oy0)], 1)
    s = inp.select(src)
    return s.with_(pos=pos, cluster=torch.arange(n), source=src,
                   feat=torch.zeros_like(s.feat))
