"""Final clean-up of a synthesized graph: no stubs or specks the exemplar does not have.

A spur is a chain from an end (degree 1) to a junction (degree >= 3); a speck is a connected
component away from the border. Output spurs shorter (in edges) than the exemplar's shortest
spur, and output specks smaller (in samples) than the exemplar's smallest one (at least 3), are
removed: optimization left-overs that would show as dangling stubs and dots. Components that
touch the border are left alone (the border cuts them, in the exemplar too).
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


def specks(g: CurveGraph, box, margin: float) -> np.ndarray:
    """Samples per component, per curve sample of a component that stays ``margin`` inside
    ``box``; 0 elsewhere. Shape: -> (N,)."""
    _, lab = components(len(g), g.edges.numpy())
    pos = g.pos.numpy()
    x0, y0, x1, y1 = box
    rim = ((pos[:, 0] < x0 + margin) | (pos[:, 0] > x1 - margin) | (pos[:, 1] < y0 + margin)
           | (pos[:, 1] > y1 - margin))
    touches = np.bincount(lab, weights=rim.astype(float)) > 0
    size = np.bincount(lab)[lab]
    return np.where((g.kind.numpy() < 0) & ~touches[lab], size, 0)


def prune(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float, keep: int = 0,
          rounds: int = 2) -> CurveGraph:
    """Remove spurs and specks smaller than the exemplar's; the first ``keep`` samples (a
    user's strokes) always stay."""
    ex_spur = min((len(c) for c in spurs(exemplar)), default=10**9)
    ex_comp = specks(exemplar, in_box, 1.5 * delta)
    min_comp = int(ex_comp[ex_comp > 0].min()) if (ex_comp > 0).any() else 3
    for _ in range(rounds):
        drop = np.zeros(len(out), dtype=bool)
        for chain in spurs(out):
            if len(chain) < ex_spur:
                drop[chain] = True
        comp = specks(out, out_box, 1.5 * delta)
        drop |= (comp > 0) & (comp < min_comp)
        drop[:keep] = False
        if not drop.any():
            break
        out = out.select(torch.from_numpy(np.nonzero(~drop)[0]))
    return out

