"""Final clean-up of a synthesized graph: no stubs or specks the exemplar does not have.

A spur is a chain from an end (degree 1) to a junction (degree >= 3); a speck is a connected
component. Output spurs shorter (in edges) than the exemplar's shortest spur, and output
components smaller (in samples) than its smallest component, are removed: optimization
left-overs that would show as dangling stubs and dots.
"""

from __future__ import annotations

import numpy as np
import torch

from cvt.curves.graph import CurveGraph, components


def spurs(g: CurveGraph) -> list[list[int]]:
    """Chains end -> junction, the junction excluded."""
    nbr = g.adjacency()
    out = []
    for v in range(len(g)):
        if len(nbr[v]) != 1:
            continue
        chain, prev, cur = [v], v, nbr[v][0]
        while len(nbr[cur]) == 2:
            chain.append(cur)
            prev, cur = cur, nbr[cur][0] if nbr[cur][0] != prev else nbr[cur][1]
        if len(nbr[cur]) >= 3:
            out.append(chain)
    return out


def _curve_components(g: CurveGraph) -> np.ndarray:
    """Samples per connected component, per curve sample. Shape: -> (N,) (0 for elements)."""
    _, lab = components(len(g), g.edges.numpy())
    size = np.bincount(lab)[lab]
    return np.where(g.kind.numpy() < 0, size, 0)


def prune(out: CurveGraph, exemplar: CurveGraph, keep: int = 0, rounds: int = 2) -> CurveGraph:
    """Remove spurs and components smaller than the exemplar's; the first ``keep`` samples
    (a user's strokes) always stay."""
    ex_spur = min((len(c) for c in spurs(exemplar)), default=10**9)
    ex_comp = _curve_components(exemplar)
    min_comp = int(ex_comp[ex_comp > 0].min()) if (ex_comp > 0).any() else 1
    for _ in range(rounds):
        drop = np.zeros(len(out), dtype=bool)
        for chain in spurs(out):
            if len(chain) < ex_spur:
                drop[chain] = True
        comp = _curve_components(out)
        drop |= (comp > 0) & (comp < min_comp)
        drop[:keep] = False
        if not drop.any():
            break
        out = out.select(torch.from_numpy(np.nonzero(~drop)[0]))
    return out
