"""Stroke ends where the exemplar has none (seed 001 sec. 4.4: no dangling stubs the exemplar
does not have; closed loops stay closed).

A coastline, a ring pattern or lace has no stroke ends inside its canvas: every stroke is
closed or runs out of the picture. An output stroke that stops in open paper is then a shape
the exemplar never shows, however few of them there are (the end statistic's floor is 1 per
100 samples, about one end per output). ``close_ends`` resolves every interior end of such an
output, nearest evidence first:

1. two ends within ``reach`` that do not point away from each other are joined;
2. the two ends of one open stroke closer than ``reach`` and than half its length close it
   (an island left open);
3. an end runs on into the nearest stroke within ``reach`` that is not straight behind it;
Each join is drawn as a bridge of samples on a smooth (Hermite) curve along the end's
tangent, not as one long straight edge, and only where the bridge stays off other strokes;
4. what is still open and has no junction (a loose open stroke, or one hanging from the
   canvas border) is removed, smallest first: the exemplar has no such piece; then stubs
   (end -> junction) are cut back to their junction, shortest first.

The first ``keep`` samples (a user's strokes in autocomplete) are never removed.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.spatial import cKDTree

from cvt.curves.ends import facing_pairs, other_end, outward, run_on, spur_chain, within_hops
from cvt.curves.graph import CurveGraph, components

SCARCE = 0.01  # exemplars with fewer interior ends per curve sample: each end a feature
REACH = 12.0  # deltas
ASIDE = -0.5  # cosine: joins may leave an end up to 120 degrees off its direction
MIN_LOOP = 6  # hops: an end is not joined to its own stroke closer than this


def _ends(g: CurveGraph, inner: np.ndarray) -> np.ndarray:
    """Interior curve ends. Shape: (N,) bool -> (M,) long."""
    return np.flatnonzero((g.degree().numpy() == 1) & (g.kind.numpy() < 0) & inner)


def _joins(g: CurveGraph, ends: np.ndarray, delta: float) -> list[tuple[int, int]]:
    """Steps 1 to 3: candidate joins for the ``ends``, nearest evidence first."""
    pos, nbr, reach = g.pos.numpy(), g.adjacency(), REACH * delta
    away = outward(pos, nbr, ends)
    new = [(a, b) for a, b in facing_pairs(pos, ends, away, reach, ASIDE)
           if b not in within_hops(nbr, a, MIN_LOOP)]
    done = {v for e in new for v in e}
    for v in ends.tolist():
        w, n = other_end(nbr, v)
        gap = np.linalg.norm(pos[v] - pos[w])
        if w > v and not {v, w} & done and n > 3 * MIN_LOOP and gap < min(0.5 * n * delta, reach):
            new.append((v, w))
            done.update((v, w))
    rest = np.array([k for k, v in enumerate(ends) if v not in done], dtype=int)
    if len(rest):
        new += run_on(pos, nbr, g.kind.numpy() < 0, ends[rest], away[rest], reach, ASIDE)
    return new


def bridge(pos: np.ndarray, nbr: list[list[int]], a: int, b: int, delta: float) -> np.ndarray:
    """Samples about ``delta`` apart strictly between ``a`` and ``b`` on the cubic Hermite
    curve leaving ``a`` along its stroke and entering ``b`` against ``b``'s (straight in where
    ``b`` lies inside a stroke). Shape: -> (K, 2), K >= 0."""
    pa, pb = pos[a], pos[b]
    span = float(np.linalg.norm(pb - pa))
    k = int(round(span / delta)) - 1
    if k <= 0:
        return np.zeros((0, 2))
    chord = (pb - pa) / max(span, 1e-12)
    ta = outward(pos, nbr, np.array([a]))[0]
    tb = -outward(pos, nbr, np.array([b]))[0] if len(nbr[b]) == 1 else chord
    t = np.linspace(0, 1, k + 2)[1:-1, None]
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    return h00 * pa + h10 * span * ta + h01 * pb + h11 * span * tb


def _clear(tree: cKDTree, path: np.ndarray, delta: float) -> bool:
    """No bridge sample lands on existing ink (closer than 0.7 ``delta``)."""
    return len(path) == 0 or bool((tree.query(path)[0] > 0.7 * delta).all())


def _bridged(g: CurveGraph, joins: list[tuple[int, int]], delta: float,
             budget: int) -> tuple[CurveGraph, int]:
    """``g`` with the joins that stay clear of other strokes drawn as bridges of samples
    (styled like the end they leave), in order while they resolve no more than ``budget``
    ends; and the ends left to resolve."""
    pos, nbr = g.pos.numpy(), g.adjacency()
    tree, n = cKDTree(pos), len(g)
    pts, style, edges = [], [], []
    for a, b in joins:
        path = bridge(pos, nbr, a, b, delta)
        cost = 2 if len(nbr[b]) == 1 else 1
        if cost > budget or not _clear(tree, path, delta):
            continue
        budget -= cost
        ids = list(range(n, n + len(path)))
        n += len(path)
        chain = [a, *ids, b]
        edges += list(zip(chain[:-1], chain[1:], strict=True))
        pts.append(path)
        style += [int(g.style[a])] * len(path)
    if not edges:
        return g, budget
    k = len(style)
    minus = torch.full((k,), -1, dtype=torch.long)
    extra = CurveGraph(torch.from_numpy(np.concatenate(pts)),
                       torch.tensor(style, dtype=torch.long), minus, minus.clone(),
                       torch.ones(k, dtype=torch.float64), minus.clone(),
                       torch.zeros(0, 2, dtype=torch.long), g.styles)
    out = g.cat(extra)
    return out.with_edges(torch.cat([out.edges, torch.tensor(edges, dtype=torch.long)])), budget


def _loose(g: CurveGraph, ends: np.ndarray, keep: int, budget: int) -> np.ndarray:
    """Samples of the smallest components that hold some of ``ends`` and no junction, while
    they hold no more than ``budget`` of them (step 4). Shape: -> (N,) bool."""
    _, lab = components(len(g), g.edges.numpy())
    junction = np.bincount(lab, weights=(g.degree().numpy() >= 3).astype(float)) > 0
    junction[lab[:keep]] = True
    count = np.bincount(lab[ends], minlength=len(junction))
    size = np.bincount(lab)
    drop = np.zeros(len(junction), dtype=bool)
    for c in np.argsort(size, kind="stable"):
        if count[c] and not junction[c] and count[c] <= budget:
            drop[c] = True
            budget -= count[c]
    return drop[lab]


def _stubs(g: CurveGraph, ends: np.ndarray, budget: int) -> np.ndarray:
    """Samples of the shortest spurs (end -> junction, the junction kept) from ``ends``, at
    most ``budget`` of them (step 4). Shape: -> (N,) bool."""
    nbr = g.adjacency()
    chains = sorted((c for c in (spur_chain(nbr, int(v), len(g)) for v in ends) if c), key=len)
    drop = np.zeros(len(g), dtype=bool)
    for c in chains[: max(budget, 0)]:
        drop[c] = True
    return drop


def close_ends(out: CurveGraph, end_rate: float, inner: np.ndarray, delta: float,
               keep: int = 0) -> CurveGraph:
    """``out`` with no more interior stroke ends than the exemplar's ``end_rate`` (interior
    ends per curve sample) allows, where that rate is under ``SCARCE``. ``inner`` (N,) bool:
    samples far enough inside the output canvas for their ends to count (border ends are the
    canvas' cut)."""
    if end_rate >= SCARCE:
        return out
    ends = _ends(out, inner)
    budget = len(ends) - int(end_rate * int((inner & (out.kind.numpy() < 0)).sum()))
    if budget <= 0:
        return out
    out, budget = _bridged(out, _joins(out, ends, delta), delta, budget)
    inner = np.r_[inner, np.ones(len(out) - len(inner), dtype=bool)]  # bridges: inside
    ends = _ends(out, inner)
    drop = _loose(out, ends, keep, budget)
    drop |= _stubs(out, ends[~drop[ends]], budget - int(drop[ends].sum()))
    drop[:keep] = False
    return out.select(torch.from_numpy(np.flatnonzero(~drop))) if drop.any() else out
