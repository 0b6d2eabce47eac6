"""Graph -> paths -> smooth Bézier SVG (seed 001 sec. 4.4.2).

At every sample the incident edges are paired into "pass through" pairs: a degree-2 sample
always joins its two edges; at a junction the most nearly opposite edges are paired while they
are at least ``straight`` degrees from collinear-opposite (the orientation-pairing rule of
sec. 4.4.2, with the edge directions as the orientations); other edges end there. Walking
through the pairs gives paths; a walk that comes back to its start is a closed path. Paths
become cubic Bézier curves through their samples (Catmull-Rom tangents, zero tangents at sharp
corners so corners stay corners) with the majority stroke style of their samples.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
import torch

from cvt.curves.graph import CurveGraph
from cvt.svg import Exemplar, to_svg

STRAIGHT = 50.0  # degrees: junction edges this close to opposite continue one path
CORNER = 70.0  # degrees of turning above which a path keeps a sharp corner


@dataclass
class Path:
    nodes: list[int]
    closed: bool
    style: int


def _pairs(g: CurveGraph, nbr: list[list[int]]) -> list[dict[int, int]]:
    """For each sample: neighbour -> the neighbour its path continues to."""
    pos = g.pos.numpy()
    out: list[dict[int, int]] = []
    lim = math.cos(math.radians(180 - STRAIGHT))
    for v, ns in enumerate(nbr):
        link: dict[int, int] = {}
        if len(ns) == 2:
            link = {ns[0]: ns[1], ns[1]: ns[0]}
        elif len(ns) > 2:
            d = pos[ns] - pos[v]
            d /= np.linalg.norm(d, axis=1, keepdims=True).clip(1e-12)
            cos = d @ d.T
            cand = sorted((cos[i, j], i, j) for i in range(len(ns)) for j in range(i + 1, len(ns)))
            for c, i, j in cand:
                if c > lim:
                    break
                if ns[i] not in link and ns[j] not in link:
                    link[ns[i]], link[ns[j]] = ns[j], ns[i]
        out.append(link)
    return out


def trace_paths(g: CurveGraph) -> list[Path]:
    """Paths through the graph's edges (every edge in exactly one path)."""
    nbr = g.adjacency()
    link = _pairs(g, nbr)
    seen: set[tuple[int, int]] = set()
    style = g.style.tolist()
    paths = []

    def walk(u: int, v: int) -> list[int]:
        chain = [u, v]
        seen.add((min(u, v), max(u, v)))
        while True:
            w = link[chain[-1]].get(chain[-2])
            if w is None or (min(chain[-1], w), max(chain[-1], w)) in seen:
                return chain
            seen.add((min(chain[-1], w), max(chain[-1], w)))
            chain.append(w)

    every = [(x, y) for x in range(len(nbr)) for y in nbr[x]]
    for a, b in [(x, y) for x, y in every if y not in link[x]] + every:  # open paths first
        if (min(a, b), max(a, b)) in seen:
            continue
        chain = walk(a, b)
        closed = len(chain) > 3 and chain[0] == chain[-1] and link[a].get(b) == chain[-2]
        if closed:
            chain = chain[:-1]
        paths.append(Path(chain, closed, Counter(style[k] for k in chain).most_common(1)[0][0]))
    return paths


def bezier_d(p: np.ndarray, closed: bool) -> str:
    """SVG path data of a smooth curve through points. Shape: p (P, 2), P >= 2."""
    n = len(p)
    ext = np.vstack([p[-1:], p, p[:2]]) if closed else np.vstack([p[:1], p, p[-1:]])
    tang = (ext[2:] - ext[:-2]) / 6  # (P + closed, 2) Catmull-Rom tangents / 3
    prev, nxt = ext[1:-1] - ext[:-2], ext[2:] - ext[1:-1]
    cosang = (prev * nxt).sum(1) / (np.linalg.norm(prev, axis=1) * np.linalg.norm(nxt, axis=1)
                                     ).clip(1e-12)
    tang[cosang < math.cos(math.radians(CORNER))] = 0.0  # keep sharp corners
    segs = n if closed else n - 1
    parts = [f"M{p[0, 0]:.2f},{p[0, 1]:.2f}"]
    for k in range(segs):
        a, b = k, (k + 1) % n
        c1, c2 = p[a] + tang[a], p[b] - tang[b]
        parts.append(f"C{c1[0]:.2f},{c1[1]:.2f} {c2[0]:.2f},{c2[1]:.2f} "
                     f"{p[b, 0]:.2f},{p[b, 1]:.2f}")
    return " ".join(parts) + ("Z" if closed else "")


def paths_svg(g: CurveGraph, paths: list[Path]) -> str:
    """``<path>`` markup of the curves, one line each, styled like the exemplar's strokes."""
    pos = g.pos.numpy()
    lines = []
    for path in paths:
        st = g.styles[path.style] if path.style >= 0 else g.styles[0]
        d = bezier_d(pos[path.nodes], path.closed)
        lines.append(f'<path d="{d}" fill="none" stroke="{st.color}" '
                     f'stroke-width="{st.width:.4g}" stroke-linecap="round" '
                     f'stroke-linejoin="round"/>')
    return "\n".join(lines)


def curves_svg(exemplar: Exemplar, centers: np.ndarray, g: CurveGraph,
               size: tuple[float, float]) -> str:
    """The whole output document: discrete elements as translated copies of their exemplar
    markup (``centers`` (E_all, 2): exemplar position of each element, indexed by element),
    then the curves as Bézier paths."""
    curve = torch.nonzero(g.kind < 0).flatten()
    disc = torch.nonzero(g.kind >= 0).flatten().tolist()
    pos = g.pos.numpy()
    place = [(int(g.element[k]), float(pos[k, 0] - centers[int(g.element[k]), 0]),
              float(pos[k, 1] - centers[int(g.element[k]), 1])) for k in disc]
    doc = to_svg(exemplar, place, size)
    sub = g.select(curve)
    markup = paths_svg(sub, trace_paths(sub))
    cut = doc.rindex("</svg>")
    return doc[:cut] + f'<g id="curves">\n{markup}\n</g>\n' + doc[cut:]
