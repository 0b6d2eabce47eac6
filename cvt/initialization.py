"""Initial output samples (seed 000 sec. 6.2).

Patch init: tile the output with square cells of size 2r and fill each with the samples of a
random input patch of the same size. Samples of one input cluster inside one copied patch share
a fresh cluster id; clusters cut at the patch border get their features recomputed.
Random init (option): samples at random places copying random input samples, one cluster each.
On a torus (tileable output, cvt.torus) the grid has a whole number of cells per period and a
random offset: a grid line is where copied patches meet, and the copies' cut elements, grown
back whole by both neighbours, crowd it; with the grid at the canvas origin the seam was such
a line every time (measured: docs/cvt_real_eval.md, "Tileable output").
Gaussian init (option, for texton exemplars): the same grid of random input patches, but each
cell copies whole elements, those whose Gaussian centre lies in the patch, and skips an element
whose centre falls inside the M = 1 ellipse of one already placed (cvt.from_textons).
"""

from __future__ import annotations

import math

import torch

from cvt.sampling import Samples
from cvt.shape_context import shape_contexts
from cvt.torus import Torus, offsets


def patch_grid(in_box, out_box, patch: float, gen: torch.Generator,
               torus: Torus | None = None) -> tuple[float, float, list[tuple[float, float]]]:
    """Cell width and height and the cells' corners (row by row) of the init grid over
    ``out_box``: cells of side ``patch`` (at most the input's) from the canvas corner, the
    last row and column cut by the canvas; on a ``torus`` a whole number of cells per
    period, at a random offset (cells across the seam wrap around)."""
    ix0, iy0, ix1, iy1 = in_box
    ox0, oy0, ox1, oy1 = out_box
    pw, ph = min(patch, ix1 - ix0), min(patch, iy1 - iy0)
    nx, ny = math.ceil((ox1 - ox0) / pw), math.ceil((oy1 - oy0) / ph)
    if torus is not None:
        nx = max(round((ox1 - ox0) / pw), math.ceil((ox1 - ox0) / (ix1 - ix0)), 1)
        ny = max(round((oy1 - oy0) / ph), math.ceil((oy1 - oy0) / (iy1 - iy0)), 1)
        pw, ph = (ox1 - ox0) / nx, (oy1 - oy0) / ny
        u = torch.rand(2, generator=gen, dtype=torch.float64)
        ox0, oy0 = ox0 + float(u[0]) * pw, oy0 + float(u[1]) * ph
    return pw, ph, [(ox0 + gx * pw, oy0 + gy * ph) for gy in range(ny) for gx in range(nx)]


def patch_init(inp: Samples, in_box, out_box, patch: float, gen: torch.Generator,
               torus: Torus | None = None) -> Samples:
    """Copy random input patches of side ``patch`` onto a grid covering ``out_box``
    (:func:`patch_grid`; on a ``torus`` positions stay unwrapped, cvt.torus).

    Boxes are (x0, y0, x1, y1) in user units.
    """
    ix0, iy0, ix1, iy1 = in_box
    ox0, oy0, ox1, oy1 = out_box
    pw, ph, cells = patch_grid(in_box, out_box, patch, gen, torus)
    parts, next_id = [], 0
    for cx, cy in cells:
        u = torch.rand(2, generator=gen, dtype=torch.float64)
        sx = ix0 + float(u[0]) * (ix1 - ix0 - pw)
        sy = iy0 + float(u[1]) * (iy1 - iy0 - ph)
        inside = ((inp.pos[:, 0] >= sx) & (inp.pos[:, 0] < sx + pw)
                  & (inp.pos[:, 1] >= sy) & (inp.pos[:, 1] < sy + ph))
        idx = torch.nonzero(inside).flatten()
        if idx.numel() == 0:
            continue
        shift = torch.tensor([cx - sx, cy - sy], dtype=inp.pos.dtype)
        s = inp.select(idx)
        _, local = torch.unique(s.cluster, return_inverse=True)
        parts.append(s.with_(pos=s.pos + shift, cluster=local + next_id, source=idx))
        next_id += int(local.max()) + 1
    if not parts:  # a sparse exemplar whose patches all came up empty
        return random_init(inp, in_box, out_box, gen)
    out = Samples.concat(parts)
    if torus is None:
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


def element_gaussians(inp: Samples) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Per input cluster: ids (E,), sample mean (E, 2) and covariance (E, 2, 2); for texton
    elements these are the segment moments of seed 003 eqs. 4.3-4.4."""
    ids, local = torch.unique(inp.cluster, return_inverse=True)
    n = torch.bincount(local).to(inp.pos.dtype)[:, None]  # (E, 1)
    mu = torch.zeros(len(ids), 2, dtype=inp.pos.dtype).index_add_(0, local, inp.pos) / n
    d = inp.pos - mu[local]  # (N, 2)
    outer = d[:, :, None] * d[:, None, :]  # (N, 2, 2)
    cov = torch.zeros(len(ids), 2, 2, dtype=inp.pos.dtype).index_add_(0, local, outer)
    return ids, mu, cov / n[:, :, None]


def gaussian_init(inp: Samples, in_box, out_box, patch: float, gen: torch.Generator,
                  torus: Torus | None = None) -> Samples:
    """Copy whole elements of random input patches of side ``patch`` onto a grid over
    ``out_box`` (:func:`patch_grid`), by their Gaussians (see the module docstring). Boxes
    are (x0, y0, x1, y1)."""
    ix0, iy0, ix1, iy1 = in_box
    ox0, oy0, ox1, oy1 = out_box
    ids, mu, cov = element_gaussians(inp)
    floor = (0.075 * patch) ** 2  # ~ (delta / 2)^2 at the default levels: tiny elements too
    prec = torch.linalg.inv(cov + floor * torch.eye(2, dtype=cov.dtype))  # (E, 2, 2)
    pw, ph, cells = patch_grid(in_box, out_box, patch, gen, torus)
    parts, centres, precs = [], [], []
    for cx, cy in cells:
        u = torch.rand(2, generator=gen, dtype=torch.float64)
        sx = ix0 + float(u[0]) * (ix1 - ix0 - pw)
        sy = iy0 + float(u[1]) * (iy1 - iy0 - ph)
        shift = torch.tensor([cx - sx, cy - sy], dtype=inp.pos.dtype)
        inside = ((mu[:, 0] >= sx) & (mu[:, 0] < sx + pw)
                  & (mu[:, 1] >= sy) & (mu[:, 1] < sy + ph))
        for e in torch.nonzero(inside).flatten().tolist():
            c = mu[e] + shift
            if centres and _covered(c, torch.stack(centres), torch.stack(precs), torus):
                continue
            idx = torch.nonzero(inp.cluster == ids[e]).flatten()
            s = inp.select(idx)
            parts.append(s.with_(pos=s.pos + shift,
                                 cluster=torch.full_like(s.cluster, len(parts)), source=idx))
            centres.append(c)
            precs.append(prec[e])
    if not parts:
        return patch_init(inp, in_box, out_box, patch, gen, torus)
    out = Samples.concat(parts)
    if torus is None:
        keep = (out.pos[:, 0] <= ox1) & (out.pos[:, 1] <= oy1)
        out = out.select(torch.nonzero(keep).flatten())
    return _refresh_cut_features(out, inp)


def _covered(c: torch.Tensor, centres: torch.Tensor, precs: torch.Tensor,
             torus: Torus | None = None) -> bool:
    """Whether point ``c`` (2,) lies inside the M = 1 ellipse of any placed Gaussian (on a
    ``torus``: of its nearest periodic image)."""
    d = offsets(c - centres, torus)  # (P, 2)
    return bool(((d[:, None, :] @ precs @ d[:, :, None]).flatten() < 1).any())
