"""Fairing of synthesized strokes before reconstruction (seed 001 sec. 4.4.2 fits smooth
curves to the output samples).

Output sample positions come from least squares over overlapping neighborhood votes (eqs.
14-15); the votes disagree by a fraction of the sampling distance, which shows as a wobble of
every stroke: straight exemplar lines come out wavy and constant-curvature rings uneven. Taubin
smoothing (a shrinking Laplacian step ``lam`` then an inflating step ``mu``) removes this
sample-to-sample noise while keeping the low-frequency shape, so circles keep their radius
(plain Laplacian smoothing would shrink them). Only degree-2 samples move; ends, junctions and
corners (turning more than ``corner`` degrees) stay where they are, and so do the first
``keep`` samples (a user's strokes in autocomplete).

How much to smooth depends on the exemplar: straight lines and round rings want the wobble
gone, cracks and scribbles are jagged on purpose. ``fair_like`` picks the number of Taubin
iterations (or plain Laplacian ones) whose output curvature histogram (cvt.curves.stats, on
the sample graph) is closest to the exemplar's: histogram matching in the spirit of Heeger and
Bergen's texture synthesis.
"""

from __future__ import annotations

import math

import torch

from cvt.curves.graph import CurveGraph
from cvt.curves.stats import curvature_hist, tv

LAM, MU = 0.5, -0.53  # Taubin's pass band: noise at the sample spacing is damped most


def chain_neighbors(g: CurveGraph) -> tuple[torch.Tensor, torch.Tensor]:
    """Degree-2 curve samples and their two neighbours. Shape: -> (M,), (M, 2)."""
    deg = g.degree()
    mid = torch.nonzero((deg == 2) & (g.kind < 0)).flatten()
    e = g.edges
    if mid.numel() == 0:
        return mid, torch.zeros(0, 2, dtype=torch.long)
    both = torch.cat([e, e.flip(1)])  # (2E, 2) directed
    both = both[torch.argsort(both[:, 0], stable=True)]
    start = torch.searchsorted(both[:, 0].contiguous(), mid)
    return mid, torch.stack([both[start, 1], both[start + 1, 1]], 1)


def turning(pos: torch.Tensor, mid: torch.Tensor, nb: torch.Tensor) -> torch.Tensor:
    """Turning angle (radians) at each degree-2 sample. Shape: -> (M,)."""
    u = pos[mid] - pos[nb[:, 0]]
    w = pos[nb[:, 1]] - pos[mid]
    cos = (u * w).sum(1) / (u.norm(dim=1) * w.norm(dim=1)).clamp_min(1e-12)
    return torch.arccos(cos.clamp(-1, 1))


def fair(g: CurveGraph, iterations: int = 3, corner: float = 60.0, keep: int = 0,
         mu: float = MU) -> CurveGraph:
    """``iterations`` Taubin (lam, mu) pairs over the free degree-2 samples (``mu = 0``:
    plain Laplacian smoothing, which straightens the strokes between fixed samples)."""
    mid, nb = chain_neighbors(g)
    if iterations <= 0 or mid.numel() == 0:
        return g
    free = (turning(g.pos, mid, nb) < math.radians(corner)) & (mid >= keep)
    mid, nb = mid[free], nb[free]
    pos = g.pos.clone()
    for _ in range(iterations):
        for step in (LAM, mu):
            lap = pos[nb].mean(1) - pos[mid]  # (M, 2) umbrella operator
            pos[mid] = pos[mid] + step * lap
    return g.with_(pos=pos)


# (iterations, mu, corner degrees); the last two keep every sample turning more than 10
# degrees: straight runs between sharp corners (a zigzag hatch) straightened, corners kept
STRENGTHS = ((0, MU, 60.0), (1, MU, 60.0), (2, MU, 60.0), (4, MU, 60.0), (2, 0.0, 60.0),
             (4, 0.0, 60.0), (8, 0.0, 60.0), (4, MU, 10.0), (1, 0.0, 10.0))


def fair_like(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float,
              keep: int = 0) -> CurveGraph:
    """``out`` faired with the strength of ``STRENGTHS`` that best matches the exemplar's
    curvature histogram (both graphs sampled at ``delta``)."""
    ref = curvature_hist(exemplar, in_box, delta)
    tries = [fair(out, k, corner, keep=keep, mu=mu) for k, mu, corner in STRENGTHS]
    err = [tv(curvature_hist(g, out_box, delta), ref) for g in tries]
    return tries[min(range(len(tries)), key=err.__getitem__)]
