"""Stroke ends the matched neighborhoods do not back (seed 001 sec. 4.3.4 edge assignment with
the expected degree of eq. 18; sec. 4.4: no dangling stubs the exemplar does not have).

After the greedy eq. 22 an output sample can be left with degree 1 although the input samples
its neighborhoods matched sit inside strokes (expected degree >= 1.5): a break the exemplar
does not have — unless the sample's own neighborhood matched an input end (``end_evidence``)
that looks like it: an input end capped by a discrete element (a circuit's pad) backs only an
output end with an element near it too.
Such *unwanted ends* are resolved with local evidence only (no global target):

1. two unwanted ends facing each other within ``reach`` are joined, nearest pairs first (a
   break closed; a loop whose two ends meet is closed again) -- unless the exemplar's own
   ends mostly face another end that close (``paired_share``: a sketch's dashed strokes);
   two side by side within half ``reach``, whatever their directions, too (the lost tip of
   a thin U-turn, a peninsula) -- unless the exemplar itself has ends side by side
   (``side_by_side``: hatching bundles, a sketch's dashes), where such a pair is a feature;
2. the two unwanted ends of one open stroke (both ends of a simple path of at least
   ``3 min_loop`` samples) within twice ``reach`` are joined: a closed stroke that the
   synthesis left open is closed again;
3. an unwanted end facing a stroke sample ahead whose own expected degree says junction
   (>= 2.5) runs on into it (a T-junction the exemplar has there);
4. (``drop_broken``) open fragments short of ``longest`` samples whose ends are both unwanted
   are removed (broken-off pieces of stroke), and so are spurs (end -> junction) that short
   from an unwanted end (stubs of a broken stroke).

``facing_pairs`` and ``outward`` are shared with the budgeted end repair of cvt.curves.cleanup.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.spatial import cKDTree

from cvt.curves.graph import CurveGraph, components

WANT_STROKE = 1.5  # expected degree above which a sample lies inside a stroke
WANT_JUNCTION = 2.5
CAP_REACH = 1.5  # a discrete element this many deltas from a stroke end caps it (a pad)


def outward(pos: np.ndarray, nbr: list[list[int]], ends: np.ndarray) -> np.ndarray:
    """Unit direction from each end's neighbour to the end. Shape: -> (M, 2)."""
    away = pos[ends] - pos[[nbr[v][0] for v in ends]]
    return away / np.linalg.norm(away, axis=1, keepdims=True).clip(1e-12)


def facing_pairs(pos: np.ndarray, ends: np.ndarray, away: np.ndarray, reach: float,
                 facing: float, style: np.ndarray | None = None) -> list[tuple[int, int]]:
    """Pairs of ends closer than ``reach`` whose outward directions point at each other
    within acos(``facing``), nearest first, each end in at most one pair; with ``style``
    (N,), only ends of one stroke style (a break lies inside one stroke: a thin line that
    stops at a thick one is not broken)."""
    if len(ends) < 2:
        return []
    pairs = cKDTree(pos[ends]).query_pairs(reach, output_type="ndarray")
    if len(pairs) == 0:
        return []
    d = pos[ends[pairs[:, 1]]] - pos[ends[pairs[:, 0]]]
    dist = np.linalg.norm(d, axis=1).clip(1e-12)
    ok = ((away[pairs[:, 0]] * d).sum(1) / dist > facing) & \
         ((-away[pairs[:, 1]] * d).sum(1) / dist > facing)
    if style is not None:
        ok &= style[ends[pairs[:, 0]]] == style[ends[pairs[:, 1]]]
    used: set[int] = set()
    out = []
    for k in np.flatnonzero(ok)[np.argsort(dist[ok], kind="stable")]:
        a, b = int(ends[pairs[k, 0]]), int(ends[pairs[k, 1]])
        if a not in used and b not in used:
            used.update((a, b))
            out.append((a, b))
    return out


def within_hops(nbr: list[list[int]], v: int, hops: int) -> set[int]:
    """Samples at most ``hops`` edges from ``v``."""
    seen, front = {v}, [v]
    for _ in range(hops):
        front = [w for u in front for w in nbr[u] if w not in seen]
        seen.update(front)
    return seen


def run_on(pos: np.ndarray, nbr: list[list[int]], target: np.ndarray, ends: np.ndarray,
           away: np.ndarray, reach: float, facing: float) -> list[tuple[int, int]]:
    """Each end joined to the nearest ``target`` (N,) bool sample ahead of it within ``reach``
    and acos(``facing``) of its outward direction ``away`` (M, 2), not its own stroke
    nearby: a T-junction."""
    tree, new = cKDTree(pos), []
    for v, a in zip(ends.tolist(), away, strict=True):
        own = within_hops(nbr, v, 4)
        best, best_d = None, np.inf
        for c in tree.query_ball_point(pos[v], reach):
            d = pos[c] - pos[v]
            dist = max(float(np.linalg.norm(d)), 1e-12)
            if c not in own and target[c] and d @ a / dist > facing and dist < best_d:
                best, best_d = c, dist
        if best is not None:
            new.append((v, best))
    return new


def end_evidence(want: np.ndarray, center_degree: np.ndarray,
                 bare: np.ndarray | None = None) -> np.ndarray:
    """Expected degrees (eq. 18) capped at 1 where the sample's own neighborhood center was
    matched to an input end; raised to a stroke's where that input end is capped by a discrete
    element (a circuit's pad) and the sample has none near it (``bare``, (N,) bool: an end
    the exemplar does not have there). Shape: (N,), (N,) -> (N,)."""
    want = np.where(center_degree == 1, np.minimum(want, 1.0), want)
    if bare is None:
        return want
    return np.where(bare, np.maximum(want, WANT_STROKE), want)


def near_element(g: CurveGraph, reach: float) -> np.ndarray:
    """Curve samples with a discrete element closer than ``reach``. Shape: -> (N,) bool."""
    pos, el = g.pos.numpy(), g.kind.numpy() >= 0
    out = np.zeros(len(g), dtype=bool)
    if el.any():
        out[~el] = cKDTree(pos[el]).query(pos[~el], distance_upper_bound=reach)[0] < reach
    return out


def capped_ends(g: CurveGraph, reach: float) -> np.ndarray:
    """Curve ends (degree 1) with a discrete element closer than ``reach``. Shape: (N,) bool."""
    return near_element(g, reach) & (g.degree().numpy() == 1)


def unwanted_ends(g: CurveGraph, want: np.ndarray) -> np.ndarray:
    """Curve samples of degree 1 whose expected degree says stroke. Shape: -> (M,) long."""
    deg = g.degree().numpy()
    return np.flatnonzero((deg == 1) & (g.kind.numpy() < 0) & (want >= WANT_STROKE))


def other_end(nbr: list[list[int]], v: int) -> tuple[int, int]:
    """The far end of the chain of degree-2 samples from end ``v``, and its length in
    samples; (-1, n) when the chain stops at a junction."""
    prev, cur, n = v, nbr[v][0], 2
    while len(nbr[cur]) == 2:
        prev, cur, n = cur, nbr[cur][0] if nbr[cur][0] != prev else nbr[cur][1], n + 1
        if cur == v:
            return -1, n
    return (cur if len(nbr[cur]) == 1 else -1), n


def _reclose(pos, nbr, ends, done: set[int], reach: float, shortest: int
             ) -> list[tuple[int, int]]:
    """Both unwanted ends of one long open path, closer than ``reach``, joined."""
    bad = set(ends.tolist()) - done
    new = []
    for v in sorted(bad):
        w, n = other_end(nbr, v)
        if (w > v and w in bad and n >= shortest
                and np.linalg.norm(pos[v] - pos[w]) < reach):
            new.append((v, w))
    return new


def paired_share(g: CurveGraph, deg: np.ndarray, reach: float, facing: float,
                 min_loop: int = 6) -> float:
    """Share of the curve ends (``deg`` (N,) == 1) that pair with another end of their style
    within ``reach`` whose outward directions point at each other within acos(``facing``)
    (< -1: whatever their directions, ends side by side)."""
    ends = np.flatnonzero((deg == 1) & (g.kind.numpy() < 0))
    if len(ends) < 2:
        return 0.0
    pos, nbr = g.pos.numpy(), g.adjacency()
    pairs = [(a, b) for a, b in facing_pairs(pos, ends, outward(pos, nbr, ends), reach, facing,
                                             g.style.numpy())
             if b not in within_hops(nbr, a, min_loop)]
    return 2 * len(pairs) / len(ends)


def side_by_side(g: CurveGraph, deg: np.ndarray, reach: float, min_loop: int = 6) -> float:
    """Share of the curve ends that pair with another end of their style within ``reach``,
    whatever their directions (ends side by side)."""
    return paired_share(g, deg, reach, -1.01, min_loop)


SIDE_BY_SIDE = 0.3  # exemplars with this share of ends side by side keep such pairs apart


def close_breaks(g: CurveGraph, want: np.ndarray, reach: float, facing: float = 0.3,
                 min_loop: int = 6, rim: np.ndarray | None = None,
                 side: bool = True, ahead: bool = True) -> CurveGraph:
    """Steps 1 to 3 above. ``want`` (N,): eq. 18 expected degrees. Two ends of one stroke
    are only joined when ``min_loop`` or more edges apart (no tiny loops). Ends on the
    ``rim`` (N,) bool (the domain border, which cuts strokes) are left as they are; ``side``
    and ``ahead``: whether ends side by side, and ends facing each other, are joined (not
    where the exemplar's own ends pair like that: a sketch's dashes)."""
    ends = unwanted_ends(g, want)
    if rim is not None:
        ends = ends[~rim[ends]]
    if len(ends) == 0:
        return g
    pos, nbr, style = g.pos.numpy(), g.adjacency(), g.style.numpy()
    away = outward(pos, nbr, ends)
    new = [(a, b) for a, b in facing_pairs(pos, ends, away, reach, facing, style)
           if b not in within_hops(nbr, a, min_loop)] if ahead else []
    done = {v for e in new for v in e}
    left = np.array([k for k, v in enumerate(ends) if v not in done], dtype=int)
    if side and len(left) > 1:
        new += [(a, b) for a, b in facing_pairs(pos, ends[left], away[left], reach / 2, -1.01,
                                                style) if b not in within_hops(nbr, a, min_loop)]
    new += _reclose(pos, nbr, ends, {v for e in new for v in e}, 2 * reach, 3 * min_loop)
    done = {v for e in new for v in e}
    rest = np.array([k for k, v in enumerate(ends) if v not in done], dtype=int)
    if len(rest):
        target = (g.kind.numpy() < 0) & (want >= WANT_JUNCTION)
        new += run_on(pos, nbr, target, ends[rest], away[rest], reach, facing)
    if not new:
        return g
    return g.with_edges(torch.cat([g.edges, torch.tensor(new, dtype=torch.long)]))


def spur_chain(nbr: list[list[int]], v: int, longest: int) -> list[int]:
    """The chain from end ``v`` up to (without) the first junction, if shorter than
    ``longest`` samples; else empty."""
    chain, prev, cur = [v], v, nbr[v][0]
    while len(nbr[cur]) == 2 and len(chain) < longest:
        chain.append(cur)
        prev, cur = cur, nbr[cur][0] if nbr[cur][0] != prev else nbr[cur][1]
    return chain if len(nbr[cur]) >= 3 and len(chain) < longest else []


def drop_broken(g: CurveGraph, want: np.ndarray, longest: int, keep: int = 0,
                rim: np.ndarray | None = None) -> CurveGraph:
    """Step 3 above: open fragments (simple paths) of fewer than ``longest`` samples whose two
    ends are unwanted, and spurs shorter than ``longest`` from an unwanted end; the first
    ``keep`` samples always stay. ``rim`` (N,) bool: samples at the domain border, where a
    stroke may end; a fragment from there to an unwanted end goes if shorter than 3
    ``longest`` (a stroke the border cut off that runs out inside)."""
    _, lab = components(len(g), g.edges.numpy())
    deg = g.degree().numpy()
    rim = np.zeros(len(g), dtype=bool) if rim is None else rim
    bad_ends = unwanted_ends(g, want)
    bad_ends = bad_ends[~rim[bad_ends]]
    size = np.bincount(lab)
    n_end = np.bincount(lab, weights=(deg == 1).astype(float), minlength=len(size))
    n_rim = np.bincount(lab, weights=((deg == 1) & rim).astype(float), minlength=len(size))
    n_bad = np.bincount(lab[bad_ends], minlength=len(size))
    held = np.bincount(lab, weights=(deg >= 3).astype(float), minlength=len(size)) > 0
    held[lab[:keep]] = True
    short = np.where(n_rim > 0, 3 * longest, longest)
    drop = ((n_end == 2) & (n_bad >= 1) & (n_bad + n_rim == 2) & (size < short) & ~held)[lab]
    nbr = g.adjacency()
    for v in bad_ends:
        drop[spur_chain(nbr, int(v), longest)] = True
    drop[:keep] = False
    if not drop.any():
        return g
    return g.select(torch.from_numpy(np.flatnonzero(~drop)))
