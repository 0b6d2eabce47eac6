"""Final clean-up of a synthesized graph: no stubs, specks or stroke ends the exemplar does
not have.

A spur is a chain from an end (degree 1) to a junction (degree >= 3); a speck is a
connected component away from the border. Output spurs shorter (in edges) than the
exemplar's shortest spur, and output specks smaller (in samples) than the exemplar's smallest
one (at least 3), are removed: optimization left-overs that would show as dangling stubs and
dots. Components that touch the border are left alone (the border cuts them, in the exemplar
too), and so do ends within 2 deltas of it.

Stroke ends are then brought to the exemplar's end density (ends per interior sample): while
the output has more, facing ends are joined (nearest pairs first), ends run on into the stroke
ahead where the exemplar has junctions, and short broken-off fragments go (``repair_ends``).
"""

from __future__ import annotations

import numpy as np
import torch

from cvt.curves.closure import close_ends
from cvt.curves.domain import deep_inside
from cvt.curves.ends import CAP_REACH, capped_ends, facing_pairs, outward, run_on
from cvt.curves.graph import CurveGraph, components

SPUR_SPAN = 2  # output spurs longer than this many times the exemplar's longest are stubs


def _interior(g: CurveGraph, box, margin: float) -> np.ndarray:
    """Samples at least ``margin`` inside ``box``: (x0, y0, x1, y1), or a domain predicate
    (a user's ``--domain`` shape, whose border cuts strokes like the canvas'). Shape: -> (N,)
    bool."""
    if callable(box):
        return deep_inside(g.pos, box, margin)
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


def open_pieces(g: CurveGraph, box, delta: float) -> np.ndarray:
    """Samples of components with a stroke end 2 ``delta`` inside ``box``. Shape: (N,) bool."""
    _, lab = components(len(g), g.edges.numpy())
    end = (g.degree().numpy() == 1) & (g.kind.numpy() < 0) & _interior(g, box, 2 * delta)
    return (np.bincount(lab, weights=end.astype(float)) > 0)[lab]


def _smallest(size: np.ndarray, where: np.ndarray, default: int) -> int:
    """The least of ``size`` > 0 at ``where``, else ``default``."""
    ok = (size > 0) & where
    return int(size[ok].min()) if ok.any() else default


def smallest_open(exemplar: CurveGraph, box, delta: float) -> int:
    """Samples of the exemplar's smallest piece with a stroke end inside ``box`` (0: none)."""
    return _smallest(specks(exemplar, box, 1.5 * delta), open_pieces(exemplar, box, delta), 0)


def prune(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float, keep: int = 0,
          rounds: int = 2) -> CurveGraph:
    """Remove spurs and specks smaller than the exemplar's, and pieces with a stroke end
    smaller than the exemplar's smallest such piece (a tangle of a letter's pen strokes torn
    off its letter: bigger than the exemplar's dots, which are closed, but open). Where the
    exemplar's stroke ends are capped by discrete elements (a circuit's pads), a small piece
    with every end capped too is a short lead like the exemplar's, not dust: it stays. The
    first ``keep`` samples (a user's strokes) always stay."""
    ex_spurs = [len(c) for c in spurs(exemplar, in_box, 2 * delta)]
    ex_spur = min(ex_spurs, default=10**9)
    # spurs far longer than the exemplar's longest: a stroke hanging out of a shape whose
    # only spurs are ticks (a gothic letter's serifs), a stub it does not have
    long_spur = SPUR_SPAN * max(ex_spurs, default=10**9)
    ex_comp = specks(exemplar, in_box, 1.5 * delta)
    min_comp = _smallest(ex_comp, np.ones(len(exemplar), dtype=bool), 3)
    min_open = smallest_open(exemplar, in_box, delta)
    pads = bool(capped_ends(exemplar, CAP_REACH * delta).any())
    for _ in range(rounds):
        drop = np.zeros(len(out), dtype=bool)
        for chain in spurs(out, out_box, 2 * delta):
            if len(chain) < ex_spur or len(chain) > long_spur:
                drop[chain] = True
        comp = specks(out, out_box, 1.5 * delta)
        small = (comp < min_comp) | ((comp < min_open) & open_pieces(out, out_box, delta))
        drop |= (comp > 0) & small & ~(_all_capped(out, delta) if pads else drop)
        drop[:keep] = False
        if not drop.any():
            break
        out = out.select(torch.from_numpy(np.nonzero(~drop)[0]))
    return out


def _all_capped(out: CurveGraph, delta: float) -> np.ndarray:
    """Samples of components with ends, all of them capped by an element. Shape: (N,) bool."""
    _, lab = components(len(out), out.edges.numpy())
    ends = (out.degree().numpy() == 1).astype(float)
    bare = ends * ~capped_ends(out, CAP_REACH * delta)
    return ((np.bincount(lab, weights=ends) > 0) & (np.bincount(lab, weights=bare) == 0))[lab]


def end_rate(g: CurveGraph, box, margin: float) -> float:
    """Ends among the curve samples ``margin`` inside ``box``."""
    inner = _interior(g, box, margin) & (g.kind.numpy() < 0)
    return float((g.degree().numpy()[inner] == 1).sum()) / max(int(inner.sum()), 1)


def excess_ends(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float) -> int:
    """Interior stroke ends of ``out`` beyond the exemplar's end density (may be < 0)."""
    inner = int((_interior(out, out_box, 2 * delta) & (out.kind.numpy() < 0)).sum())
    ex_rate = end_rate(exemplar, in_box, 2 * delta)
    return int(np.floor((end_rate(out, out_box, 2 * delta) - ex_rate) * inner))


def join_ends(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float,
              reach: float = 4.0, facing: float = 0.3) -> CurveGraph:
    """While the output has more interior stroke ends than the exemplar's density, join pairs
    of facing ends (each end's outward direction points at the other within acos(``facing``),
    closer than ``reach`` deltas, both inside), nearest pairs first: breaks the exemplar does
    not have."""
    deg = out.degree().numpy()
    inner = _interior(out, out_box, 2 * delta)
    ends = np.flatnonzero((deg == 1) & (out.kind.numpy() < 0) & inner)
    budget = excess_ends(out, exemplar, in_box, out_box, delta) // 2
    if len(ends) < 2 or budget <= 0:
        return join_to_strokes(out, exemplar, in_box, out_box, delta)
    pos, nbr = out.pos.numpy(), out.adjacency()
    new = facing_pairs(pos, ends, outward(pos, nbr, ends), reach * delta, facing)[:budget]
    if new:
        out = out.with_edges(torch.cat([out.edges, torch.tensor(new, dtype=torch.long)]))
    return join_to_strokes(out, exemplar, in_box, out_box, delta)


def join_to_strokes(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float,
                    reach: float = 4.0, facing: float = 0.3) -> CurveGraph:
    """Where the exemplar has junctions, ends still beyond its end density run on into the
    nearest stroke ahead (a T-junction, closer than ``reach`` deltas, within acos(``facing``)
    of the end's outward direction)."""
    budget = excess_ends(out, exemplar, in_box, out_box, delta)
    inner = _interior(exemplar, in_box, 2 * delta)
    if budget <= 0 or not (exemplar.degree().numpy()[inner] >= 3).any():
        return out
    deg, pos, nbr = out.degree().numpy(), out.pos.numpy(), out.adjacency()
    curve = out.kind.numpy() < 0
    ends = np.flatnonzero((deg == 1) & curve & _interior(out, out_box, 2 * delta))[:budget]
    new = run_on(pos, nbr, curve, ends, outward(pos, nbr, ends), reach * delta, facing)
    if not new:
        return out
    return out.with_edges(torch.cat([out.edges, torch.tensor(new, dtype=torch.long)]))


def drop_fragments(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float,
                   longest: int = 8, keep: int = 0) -> CurveGraph:
    """While the output still has more interior ends than the exemplar's density, remove its
    open fragments (simple paths, both ends inside) of fewer than ``longest`` samples,
    shortest first: broken-off stroke pieces. The first ``keep`` samples always stay."""
    budget = excess_ends(out, exemplar, in_box, out_box, delta)
    if budget < 2:
        return out
    deg = out.degree().numpy()
    _, lab = components(len(out), out.edges.numpy())
    rim = ~_interior(out, out_box, 2 * delta) | (deg >= 3) | (out.kind.numpy() >= 0)
    rim[:keep] = True
    bad = np.bincount(lab, weights=rim.astype(float)) > 0
    size = np.bincount(lab)
    cand = [c for c in np.argsort(size, kind="stable") if not bad[c] and 2 <= size[c] < longest]
    drop = np.zeros(len(out), dtype=bool)
    for c in cand[: budget // 2]:
        drop |= lab == c
    return out.select(torch.from_numpy(np.flatnonzero(~drop))) if drop.any() else out


def repair_ends(out: CurveGraph, exemplar: CurveGraph, in_box, out_box, delta: float,
                keep: int = 0) -> CurveGraph:
    """Stroke ends beyond the exemplar's end density: joined where two face each other, else
    their short broken-off fragments removed; none left where the exemplar has none
    (cvt.curves.closure)."""
    out = join_ends(out, exemplar, in_box, out_box, delta)
    out = drop_fragments(out, exemplar, in_box, out_box, delta, keep=keep)
    return close_ends(out, end_rate(exemplar, in_box, 2 * delta),
                      _interior(out, out_box, 2 * delta), delta, keep=keep)
