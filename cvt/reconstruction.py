"""Reconstruction (seed 000 sec. 6.6): each output cluster becomes a translated input element.

The element is the one of the candidate input cluster that minimizes the shape energy
(seed 000 eq. 15, shape_energy.py), translated by seed 000 eq. 17. Filtering drops elements
whose cluster shape energy is high, E'_s(C_o) > |C_o|: broken or stray clusters. Depth order
(depth.py) sorts the result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from cvt.sampling import Samples
from cvt.search import Matches
from cvt.shape_energy import ShapeEnergy


@dataclass(frozen=True)
class Placement:
    cluster: int  # output cluster id
    element: int  # input element (== input cluster id)
    dx: float
    dy: float
    energy: float  # shape energy E'_s of the output cluster (seed 000 eq. 15)
    z: int  # z-index of the input element
    size: int = 0  # number of samples in the output cluster, |C_o|


def reconstruct(out: Samples, inp: Samples, m: Matches, delta: float,
                shape: ShapeEnergy | None = None) -> list[Placement]:
    """Pick an input element and translation for every output cluster (seed 000 eqs. 15-17).

    Returned in input z order (ties by cluster id); ``shape`` may be a ShapeEnergy built for
    the same positions and field (its memo is reused).
    """
    shape = shape or ShapeEnergy(out.pos, m.center, inp.pos, inp.cluster, delta)
    o_cl = out.cluster.numpy()
    order = np.argsort(o_cl, kind="stable")
    ids, start = np.unique(o_cl[order], return_index=True)
    first = {int(c): int(inp.element[inp.cluster == c][0]) for c in inp.cluster.unique()}
    z_of = {int(c): int(inp.z[inp.cluster == c][0]) for c in inp.cluster.unique()}
    placements = []
    for c, mem in zip(ids.tolist(), np.split(order, start[1:]), strict=True):
        fit = shape(mem)
        placements.append(Placement(c, first[fit.cluster], *fit.shift, fit.energy,
                                    z_of[fit.cluster], len(mem)))
    placements.sort(key=lambda p: (p.z, p.cluster))
    return placements


def filter_placements(placements: list[Placement]) -> list[Placement]:
    """Sec. 6.6: drop elements with high shape energy, E'_s(C_o) > |C_o|."""
    return [p for p in placements if p.energy <= p.size]


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
