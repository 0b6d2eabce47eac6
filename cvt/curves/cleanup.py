"""Final clean-up of a synthesized graph: no stubs or specks the exemplar does not have.

Where the exemplar's strokes do not end inside it, facing ends closer than a few deltas are
joined. A spur is a chain from an end (degree 1) to a junction (degree >= 3); a speck is a
connected component away from the border. Output spurs shorter (in edges) than the
exemplar's shortest spur, and output specks smaller (in samples) than the exemplar's smallest
one (at least 3), are removed: optimization left-overs that would show as dangling stubs and
dots. Components that touch the border are left alone (the border cuts them, in the exemplar
too), and so do ends within 2 deltas of it.
"""

from __future__ import annotations

import numpy as np
import torch

from cvt.curves.graph import CurveGraph, components


def _interior(g: CurveGraph, box, margin: float) -> np.ndarray:
    """Samples at least ``margin`` inside ``box``. Shape: -> (N,) bool."""
    pos = g.pos.numpy()
    x0, y0, x1, y1 = box
    return ((pos[:, 0] >= x0 + margin) & (pos[:, 0] <= x1 - margin) & (pos[:, 1] >= y0 + margin)
            & (pos[:, 1] <= y1 - margin))


def spurs(g: CurveGraph, box, margin: float) -> list[list[int]]:
    """Chains end -> junction, the junction excluded, from ends ``margin`` inside ``box``."""
    nbr = g.adjacency()
    inner = _interior(g, box, margin)
    out = []
    for v in range(len(g)):
        if len(nbr[v]) != 1 or not inner[v]:
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
    rim = ~_interior(g, box, margin)
    touches = np.bincount(lab, weights=rim.astype(float)) > 0
    size = np.bincount(lab)[lab]
    return np.where((g.kind.numpy() < 0) & ~touches[lab], size, 0)


def prune(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float, keep: int = 0,
          rounds: int = 2) -> CurveGraph:
    """Remove spurs and specks smaller than the exemplar's; the first ``keep`` samples (a
    user's strokes) always stay."""
    ex_spur = min((len(c) for c in spurs(exemplar, in_box, 2 * delta)), default=10**9)
    ex_comp = specks(exemplar, in_box, 1.5 * delta)
    min_comp = int(ex_comp[ex_comp > 0].min()) if (ex_comp > 0).any() else 3
    for _ in range(rounds):
        drop = np.zeros(len(out), dtype=bool)
        for chain in spurs(out, out_box, 2 * delta):
            if len(chain) < ex_spur:
                drop[chain] = True
        comp = specks(out, out_box, 1.5 * delta)
        drop |= (comp > 0) & (comp < min_comp)
        drop[:keep] = False
        if not drop.any():
            break
        out = out.select(torch.from_numpy(np.nonzero(~drop)[0]))
    return out



def end_rate(g: CurveGraph, box, margin: float) -> float:
    """Ends among the curve samples ``margin`` inside ``box``."""
    inner = _interior(g, box, margin) & (g.kind.numpy() < 0)
    return float((g.degree().numpy()[inner] == 1).sum()) / max(int(inner.sum()), 1)


def join_ends(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float,
              reach: float = 3.0, facing: float = 0.5, rare: float = 0.01) -> CurveGraph:
    """For exemplars whose strokes (almost) never end inside (end rate below ``rare``), join
    pairs of facing stroke ends (each end's outward direction points at the other, closer than
    ``reach`` deltas), nearest pairs first: breaks the exemplar does not have."""
    from scipy.spatial import cKDTree

    deg = out.degree().numpy()
    ends = np.flatnonzero((deg == 1) & (out.kind.numpy() < 0))
    ex_rate = end_rate(exemplar, in_box, 2 * delta)
    excess = round((end_rate(out, out_box, 2 * delta) - ex_rate) * len(out) / 2)
    if len(ends) < 2 or excess <= 0 or ex_rate >= rare:
        return out
    pos, nbr = out.pos.numpy(), out.adjacency()
    away = pos[ends] - pos[[nbr[v][0] for v in ends]]
    away /= np.linalg.norm(away, axis=1, keepdims=True).clip(1e-12)
    pairs = cKDTree(pos[ends]).query_pairs(reach * delta, output_type="ndarray")
    d = pos[ends[pairs[:, 1]]] - pos[ends[pairs[:, 0]]]
    dist = np.linalg.norm(d, axis=1).clip(1e-12)
    ok = ((away[pairs[:, 0]] * d).sum(1) / dist > facing) & \
         ((-away[pairs[:, 1]] * d).sum(1) / dist > facing)
    used, new = set(), []
    for k in np.flatnonzero(ok)[np.argsort(dist[ok])]:
        a, b = ends[pairs[k, 0]], ends[pairs[k, 1]]
        if a in used or b in used or len(new) >= excess:
            continue
        used.update((a, b))
        new.append((a, b))
    if not new:
        return out
    return out.with_edges(torch.cat([out.edges, torch.tensor(new, dtype=torch.long)]))
