"""Statistics of curve patterns, for evaluation (scripts/eval_curves.py) and tests.

Both the exemplar and an output are measured the same way: their SVG is read back and sampled
at one spacing ``delta`` (cvt.curves.sampling), and only samples at least ``margin`` deltas
inside the box count (path ends cut by the box border are not pattern ends).

* degree histogram over degrees 1, 2, 3, 4+ (shares), compared by total variation;
* end and junction densities, per 100 counted samples, compared by relative error with a floor
  of 1 per 100 (patterns without ends would otherwise divide by zero);
* loops: cycle rank (edges - samples + components) per 100 samples;
* curvature: turning angle / edge length at degree-2 samples, times delta, histogram (TV)
  with linear (soft) binning: a value splits between the two nearest bin centres, so a
  pattern whose curvature sits on a bin edge (lace rings: 0.505 against the edge 0.5) is not
  judged by which side of the edge a 1 % change lands on;
* segment lengths: paths between ends and junctions, in deltas, histogram (TV).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from cvt.curves.graph import CurveGraph, components

CURV_CENTERS = np.linspace(0.05, 1.25, 13)  # bins 0.1 wide; the last collects >= 1.2
SEG_BINS = np.r_[0, 2, 4, 8, 16, 32, 64, np.inf]
FLOOR = 1.0  # per 100 samples


@dataclass
class GraphStats:
    degree: np.ndarray  # (4,) shares of degrees 1, 2, 3, 4+
    ends: float  # per 100 samples
    junctions: float
    loops: float
    curvature: np.ndarray  # (13,) soft histogram shares
    segments: np.ndarray  # (7,) histogram shares
    samples: int


def _hist(x: np.ndarray, bins: np.ndarray) -> np.ndarray:
    h = np.histogram(x, bins)[0].astype(float)
    return h / max(h.sum(), 1)


def soft_hist(x: np.ndarray, centers: np.ndarray) -> np.ndarray:
    """Histogram with linear binning over evenly spaced ``centers``. Shape: (M,) -> (B,)."""
    step = centers[1] - centers[0]
    t = (np.clip(x, centers[0], centers[-1]) - centers[0]) / step
    lo = np.minimum(np.floor(t).astype(int), len(centers) - 2)
    w = t - lo
    h = np.bincount(lo, 1 - w, len(centers)) + np.bincount(lo + 1, w, len(centers))
    return h / max(h.sum(), 1)


def _turning(g: CurveGraph, counted: np.ndarray, delta: float) -> np.ndarray:
    """Curvature times delta at counted degree-2 samples. Shape: -> (M,)."""
    pos = g.pos.numpy()
    nbr = g.adjacency()
    out = []
    for v in np.nonzero(counted)[0]:
        if len(nbr[v]) != 2:
            continue
        u, w = pos[nbr[v][0]] - pos[v], pos[nbr[v][1]] - pos[v]
        lu, lw = np.linalg.norm(u), np.linalg.norm(w)
        cos = np.clip(-(u @ w) / max(lu * lw, 1e-12), -1, 1)
        out.append(np.arccos(cos) / max((lu + lw) / 2, 1e-12) * delta)
    return np.array(out)


def _segments(g: CurveGraph, delta: float) -> np.ndarray:
    """Lengths (in deltas) of the paths between samples of degree != 2."""
    from cvt.curves.reconstruction import trace_paths

    pos = g.pos.numpy()
    deg = g.degree().numpy()
    lens = []
    for p in trace_paths(g):
        pts = pos[p.nodes]
        cuts = [k for k, v in enumerate(p.nodes) if deg[v] != 2 and 0 < k < len(p.nodes) - 1]
        bounds = [0, *cuts, len(p.nodes) - 1]
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            lens.append(np.linalg.norm(np.diff(pts[a : b + 1], axis=0), axis=1).sum() / delta)
    return np.array(lens)


def counted_samples(g: CurveGraph, box, delta: float, margin: float = 2.0) -> np.ndarray:
    """Curve samples with edges at least ``margin`` deltas inside ``box``. Shape: -> (N,)."""
    pos, deg = g.pos.numpy(), g.degree().numpy()
    x0, y0, x1, y1 = box
    m = margin * delta
    return ((pos[:, 0] > x0 + m) & (pos[:, 0] < x1 - m) & (pos[:, 1] > y0 + m)
            & (pos[:, 1] < y1 - m) & (deg > 0) & (g.kind.numpy() < 0))


def curvature_hist(g: CurveGraph, box, delta: float) -> np.ndarray:
    """The curvature statistic alone (soft histogram). Shape: -> (13,)."""
    return soft_hist(_turning(g, counted_samples(g, box, delta), delta), CURV_CENTERS)


def graph_stats(g: CurveGraph, box, delta: float, margin: float = 2.0) -> GraphStats:
    """Statistics of the curve samples of ``g`` inside ``box`` (x0, y0, x1, y1)."""
    curve = np.nonzero(g.kind.numpy() < 0)[0]
    g = g.select(torch.from_numpy(curve))
    deg = g.degree().numpy()
    counted = counted_samples(g, box, delta, margin)
    n = max(int(counted.sum()), 1)
    d = np.clip(deg[counted], 1, 4)
    n_comp = components(len(g), g.edges.numpy())[0] if len(g) else 0
    return GraphStats(
        degree=np.bincount(d - 1, minlength=4)[:4] / n,
        ends=100 * float((deg[counted] == 1).sum()) / n,
        junctions=100 * float((deg[counted] >= 3).sum()) / n,
        loops=100 * max(len(g.edges) - len(g) + n_comp, 0) / max(len(g), 1),
        curvature=soft_hist(_turning(g, counted, delta), CURV_CENTERS),
        segments=_hist(_segments(g, delta), SEG_BINS),
        samples=n)


def tv(a: np.ndarray, b: np.ndarray) -> float:
    """Total variation distance of two histograms."""
    return 0.5 * float(np.abs(a - b).sum())


def rel(out: float, ref: float) -> float:
    """Relative error with a floor for (near) zero references."""
    return abs(out - ref) / max(ref, FLOOR)


def compare(out: GraphStats, ref: GraphStats) -> dict[str, float]:
    return {"degree_tv": tv(out.degree, ref.degree), "ends_rel": rel(out.ends, ref.ends),
            "junctions_rel": rel(out.junctions, ref.junctions),
            "loops_rel": rel(out.loops, ref.loops),
            "curvature_tv": tv(out.curvature, ref.curvature),
            "segments_tv": tv(out.segments, ref.segments)}
