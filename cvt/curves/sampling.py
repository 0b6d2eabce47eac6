"""Strokes -> sample graph at spacing delta (seed 001 sec. 4.1.1, continuous structures).

Intersections (crossings) and path ends that touch another path (T-junctions, joined ends)
become shared graph nodes; the pieces of stroke between such nodes get uniformly spaced
samples about ``delta`` apart, chained by edges. Work is bounded: strokes are first resampled
at delta / 4 (so 10^5 tiny segments cost the same as a few long ones) and candidate segment
pairs come from a k-d tree.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.spatial import cKDTree

from cvt.curves.graph import CurveGraph, StrokeStyle, canonical_edges
from cvt.curves.strokes import CurveExemplar, Stroke

FINE = 4  # strokes are resampled at delta / FINE before junction detection
MAX_NODES = 400_000


def resample(points: np.ndarray, closed: bool, step: float) -> np.ndarray:
    """Points every ~``step`` along a polyline, ends kept. Shape: (P, 2) -> (Q, 2)."""
    p = np.vstack([points, points[:1]]) if closed else points
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(seg)]
    n = max(int(np.ceil(s[-1] / step)), 3 if closed else 1)
    t = np.linspace(0.0, s[-1], n + 1)
    q = np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], 1)
    return q[:-1] if closed else q


class _Union:
    def __init__(self):
        self.parent: list[int] = []

    def add(self) -> int:
        self.parent.append(len(self.parent))
        return len(self.parent) - 1

    def find(self, a: int) -> int:
        while self.parent[a] != a:
            self.parent[a] = self.parent[self.parent[a]]
            a = self.parent[a]
        return a

    def join(self, a: int, b: int) -> None:
        self.parent[self.find(a)] = self.find(b)


def _segments(strokes: list[Stroke]):
    """All segments. Shape: -> a, b (S, 2), stroke (S,), arc length at a (S,)."""
    a, b, sid, arc = [], [], [], []
    for k, st in enumerate(strokes):
        p = np.vstack([st.points, st.points[:1]]) if st.closed else st.points
        seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
        a.append(p[:-1])
        b.append(p[1:])
        sid.append(np.full(len(seg), k))
        arc.append(np.r_[0.0, np.cumsum(seg)[:-1]])
    return np.vstack(a), np.vstack(b), np.concatenate(sid), np.concatenate(arc)


def _crossings(a, b, sid, arc, lengths, step: float):
    """Proper intersections of non-adjacent segments. Shape: -> (X, 2) pairs, (X,) t, u."""
    mid = (a + b) / 2
    pairs = cKDTree(mid).query_pairs(1.01 * step, output_type="ndarray")  # (P, 2)
    if len(pairs) == 0:
        return pairs, np.zeros(0), np.zeros(0)
    i, j = pairs[:, 0], pairs[:, 1]
    d1, d2 = b[i] - a[i], b[j] - a[j]
    den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    w = a[j] - a[i]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[:, 0] * d2[:, 1] - w[:, 1] * d2[:, 0]) / den
        u = (w[:, 0] * d1[:, 1] - w[:, 1] * d1[:, 0]) / den
    hit = (np.abs(den) > 1e-12) & (t > 0) & (t <= 1) & (u > 0) & (u <= 1)
    # neighbours along one stroke always "touch"; only far-apart parts of a stroke may cross
    same = sid[i] == sid[j]
    gap = np.abs(arc[i] - arc[j])
    gap = np.minimum(gap, lengths[sid[i]] - gap)
    hit &= ~same | (gap > 2.5 * step)
    return pairs[hit], t[hit], u[hit]


def _events(strokes: list[Stroke], step: float, snap: float, uf: _Union):
    """Cut events per stroke: lists of (arc length, node id, position)."""
    lengths = np.array([_len(s) for s in strokes])
    a, b, sid, arc = _segments(strokes)
    seglen = np.linalg.norm(b - a, axis=1)
    events: list[list[tuple[float, int, np.ndarray]]] = [[] for _ in strokes]
    pairs, t, u = _crossings(a, b, sid, arc, lengths, step)
    for (i, j), ti, uj in zip(pairs, t, u, strict=True):
        node = uf.add()
        p = a[i] + ti * (b[i] - a[i])
        events[sid[i]].append((arc[i] + ti * seglen[i], node, p))
        events[sid[j]].append((arc[j] + uj * seglen[j], node, p))
    opened = [k for k, st in enumerate(strokes) if not st.closed]
    ends = [(k, p, s) for k in opened
            for p, s in ((strokes[k].points[0], 0.0), (strokes[k].points[-1], lengths[k]))]
    if not ends:
        return events, lengths
    hits = _snap_ends(np.array([p for _, p, _ in ends]), np.array([s for _, _, s in ends]),
                      np.array([k for k, _, _ in ends]), (a, b, sid, arc, seglen), lengths,
                      snap, step)
    for (k, p, s), (i, s_hit, q) in zip(ends, hits, strict=True):
        node = uf.add()
        events[k].append((s, node, p))
        if i >= 0:  # a path end within ``snap`` of another part of the pattern joins it there
            events[sid[i]].append((s_hit, node, q))
    return events, lengths


def _snap_ends(ends, s_end, owner, segs, lengths, snap: float, step: float):
    """Where each path end (M, 2) within ``snap`` of another part of the pattern joins it:
    (segment or -1, arc length there, point) per end, the nearest segment point first."""
    a, b, sid, arc, seglen = segs
    near = cKDTree((a + b) / 2).query_ball_point(ends, snap + step)
    ei = np.repeat(np.arange(len(ends)), [len(n) for n in near])
    si = np.fromiter((i for n in near for i in n), dtype=int, count=len(ei))
    d = b[si] - a[si]
    t = np.clip(((ends[ei] - a[si]) * d).sum(1) / np.maximum((d * d).sum(1), 1e-300), 0, 1)
    s = arc[si] + t * seglen[si]
    gap = np.abs(s - s_end[ei])
    own = (sid[si] == owner[ei]) & (np.minimum(gap, lengths[owner[ei]] - gap) < 3 * snap)
    q = a[si] + t[:, None] * d
    dist = np.linalg.norm(q - ends[ei], axis=1)
    ok = np.flatnonzero(~own & (dist < snap))
    out = [(-1, 0.0, None)] * len(ends)
    order = np.lexsort((si[ok], np.round(dist[ok] / snap, 9)))  # ties: the lowest segment
    for k in ok[order][::-1]:  # the nearest last, so it wins
        out[ei[k]] = (int(si[k]), float(s[k]), q[k])
    return out


def _len(st: Stroke) -> float:
    p = np.vstack([st.points, st.points[:1]]) if st.closed else st.points
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


class _Builder:
    """Accumulates nodes (junction nodes by union-find root) and edges."""

    def __init__(self, uf: _Union):
        self.uf = uf
        self.root_node: dict[int, int] = {}
        self.pos: list[np.ndarray] = []
        self.style: list[int] = []
        self.edges: list[tuple[int, int]] = []
        self.junction_sum: dict[int, list] = {}

    def junction(self, node: int, p: np.ndarray, style: int) -> int:
        r = self.uf.find(node)
        if r not in self.root_node:
            self.root_node[r] = self.add(p, style)
            self.junction_sum[self.root_node[r]] = [np.zeros(2), 0]
        k = self.root_node[r]
        acc = self.junction_sum[k]
        acc[0] = acc[0] + p
        acc[1] += 1
        return k

    def add(self, p: np.ndarray, style: int) -> int:
        if len(self.pos) >= MAX_NODES:
            from neuraltex.errors import InputError

            raise InputError(f"pattern too large: more than {MAX_NODES:,} samples")
        self.pos.append(p)
        self.style.append(style)
        return len(self.pos) - 1

    def positions(self) -> np.ndarray:
        pos = np.array(self.pos).reshape(-1, 2)
        for k, (s, c) in self.junction_sum.items():
            pos[k] = s / c
        return pos


def _arc(points: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """The stroke's points (closed: the first repeated) and their arc lengths."""
    p = np.vstack([points, points[:1]]) if closed else points
    return p, np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]


def _at(arc: tuple[np.ndarray, np.ndarray], closed: bool, s: np.ndarray) -> np.ndarray:
    """Points at arc lengths ``s`` (wrapped on closed strokes) of ``arc`` (``_arc``).
    Shape: (Q,) -> (Q, 2)."""
    p, cum = arc
    s = np.mod(s, cum[-1]) if closed else s
    return np.stack([np.interp(s, cum, p[:, 0]), np.interp(s, cum, p[:, 1])], 1)


def _merge_close(ev, length: float, closed: bool, gap: float, uf: _Union):
    """Sort events along a stroke, merging ones closer than ``gap`` (same node)."""
    ev = sorted(ev, key=lambda e: e[0])
    out = []
    for e in ev:
        if out and e[0] - out[-1][0] < gap:
            uf.join(e[1], out[-1][1])
        else:
            out.append(e)
    if closed and len(out) > 1 and out[0][0] + length - out[-1][0] < gap:
        uf.join(out[-1][1], out[0][1])
        out.pop()
    return out


def _pieces(st: Stroke, ev, length: float, delta: float, bld: _Builder) -> None:
    """Samples and edges of one stroke between its cut events."""
    if st.closed and not ev:
        ev = [(0.0, bld.uf.add(), st.points[0])]
    nodes = [bld.junction(n, p, st.style) for _, n, p in ev]
    arcs = [s for s, _, _ in ev]
    spans = [(k, k + 1) for k in range(len(ev) - 1)]
    along = _arc(st.points, st.closed)
    if st.closed:
        spans.append((len(ev) - 1, 0))
    for i, j in spans:
        s0, s1 = arcs[i], arcs[j] + (length if j <= i else 0.0)
        if s1 - s0 <= 1e-12:
            continue
        loop = bld.uf.find(ev[i][1]) == bld.uf.find(ev[j][1])
        n = max(int(round((s1 - s0) / delta)), 3 if loop else 1)
        inner = _at(along, st.closed, np.linspace(s0, s1, n + 1)[1:-1])
        chain = [nodes[i]] + [bld.add(q, st.style) for q in inner] + [nodes[j]]
        bld.edges.extend(zip(chain[:-1], chain[1:], strict=True))


def stroke_graph(strokes: list[Stroke], styles: list[StrokeStyle], delta: float) -> CurveGraph:
    """Sample graph of the strokes: junctions, ends and samples ~``delta`` apart."""
    step = delta / FINE
    total = sum(_len(s) for s in strokes) / step
    if total > 4 * MAX_NODES:
        from neuraltex.errors import InputError

        raise InputError(f"strokes too long for their sampling: {total:,.0f} points at spacing "
                         f"{step:.3g} (limit {4 * MAX_NODES:,})")
    fine = [Stroke(resample(s.points, s.closed, step), s.closed, s.style) for s in strokes]
    uf = _Union()
    events, lengths = _events(fine, step, 0.3 * delta, uf)
    bld = _Builder(uf)
    merged = [_merge_close(ev, lengths[k], st.closed, 0.5 * delta, uf)
              for k, (st, ev) in enumerate(zip(fine, events, strict=True))]
    for k, st in enumerate(fine):
        _pieces(st, merged[k], lengths[k], delta, bld)
    pos = torch.from_numpy(bld.positions())
    n = pos.shape[0]
    edges = torch.tensor(bld.edges, dtype=torch.long).reshape(-1, 2)
    minus = torch.full((n,), -1, dtype=torch.long)
    return CurveGraph(pos, torch.tensor(bld.style, dtype=torch.long), minus, minus.clone(),
                      torch.ones(n, dtype=torch.float64), minus.clone(), canonical_edges(edges),
                      styles)


def exemplar_graph(cx: CurveExemplar, delta: float) -> CurveGraph:
    """Strokes and discrete elements (one sample each, kind = same-size group) of an exemplar."""
    g = stroke_graph(cx.strokes, cx.styles, delta)
    if not cx.elements:
        return g
    centers = torch.from_numpy(cx.element_centers()[cx.elements])
    boxes = [cx.exemplar.elements[i].bbox for i in cx.elements]
    sig = [(round((b[2] - b[0]) / delta * 2), round((b[3] - b[1]) / delta * 2)) for b in boxes]
    kinds = {s: k for k, s in enumerate(dict.fromkeys(sig))}
    d = centers.shape[0]
    minus = torch.full((d,), -1, dtype=torch.long)
    el = CurveGraph(centers, minus, torch.tensor([kinds[s] for s in sig]),
                    torch.tensor(cx.elements), torch.ones(d, dtype=torch.float64), minus.clone(),
                    torch.zeros(0, 2, dtype=torch.long), cx.styles)
    return g.cat(el)
