"""Autocomplete (seed 001 sec. 3): predict the strokes around what a user has drawn so far.

The user's strokes are sampled at the exemplar's finest spacing and held fixed (positions,
edges, never removed, never outliers); the region around them is filled by the curve synthesis
(two levels by default), whose neighborhoods overlap the user's strokes, so the prediction continues
them and may join them. Drawn samples farther than two neighbourhood radii (of each level) from
the region cannot influence it and are left out. The result is the predicted strokes (the edges
not between two of the user's samples).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import torch

from cvt.curves.cleanup import prune, repair_ends
from cvt.curves.fairing import fair_like
from cvt.curves.graph import CurveGraph
from cvt.curves.init import box_inside
from cvt.curves.sampling import stroke_graph
from cvt.curves.spacing import curve_levels
from cvt.curves.strokes import CurveExemplar, Stroke
from cvt.curves.synthesis import CurveConfig, run_boxed


@dataclass
class Completion:
    graph: CurveGraph  # the user's samples near the box first (n_fixed), then the predicted
    n_fixed: int
    box: tuple[float, float, float, float]
    seconds: float

    def predicted(self) -> CurveGraph:
        """Only the new strokes (edges touching a predicted sample) and their samples."""
        e = self.graph.edges
        new = (e >= self.n_fixed).any(1) if e.numel() else torch.zeros(0, dtype=torch.bool)
        g = self.graph.with_(edges=e[new])
        used = torch.zeros(len(g), dtype=torch.bool)
        used[g.edges.flatten()] = True
        used[self.n_fixed :] = True
        return g.select(torch.nonzero(used).flatten())


def user_strokes(cx: CurveExemplar, partial: CurveExemplar
                 ) -> tuple[CurveExemplar, list[Stroke]]:
    """The partial drawing's strokes, and the exemplar with the drawing's styles appended to
    its style list (so both index one list)."""
    styles = list(cx.styles)
    remap = []
    for st in partial.styles:
        if st not in styles:
            styles.append(st)
        remap.append(styles.index(st))
    strokes = [Stroke(s.points, s.closed, remap[s.style]) for s in partial.strokes]
    return replace(cx, styles=styles), strokes


def region_around(partial: CurveExemplar, margin: float):
    """The partial drawing's stroke bounding box grown by ``margin``, inside its canvas."""
    import numpy as np

    pts = np.concatenate([s.points for s in partial.strokes])
    x0, y0, x1, y1 = partial.box
    lo, hi = pts.min(0) - margin, pts.max(0) + margin
    return (max(x0, lo[0]), max(y0, lo[1]), min(x1, hi[0]), min(y1, hi[1]))


def autocomplete(cx: CurveExemplar, partial: CurveExemplar, box, config: CurveConfig | None = None
                 ) -> Completion:
    """Predict strokes inside ``box`` (x0, y0, x1, y1) around the ``partial`` drawing."""
    cfg = config or CurveConfig(levels=2)
    cx, strokes = user_strokes(cx, partial)
    levels = curve_levels(cx, cfg)
    radius = {lv.delta: lv.radius for lv in levels}
    done: dict[float, CurveGraph] = {}

    def drawn(delta: float) -> CurveGraph:  # farther drawn samples change nothing
        if delta not in done:
            reach = 2 * radius.get(delta, levels[0].radius)
            g = stroke_graph(strokes, cx.styles, delta)
            grown = (box[0] - reach, box[1] - reach, box[2] + reach, box[3] + reach)
            done[delta] = g.select(torch.nonzero(box_inside(grown)(g.pos)).flatten())
        return done[delta]

    delta = levels[-1].delta
    fixed = len(drawn(delta))
    res = run_boxed(cx, box, cfg, None, drawn, levels=levels)
    g = repair_ends(res.graph, res.inputs[-1], cx.box, box, delta, keep=fixed)
    g = prune(g, res.inputs[-1], cx.box, box, delta, keep=fixed)
    g = fair_like(g, res.inputs[-1], cx.box, box, delta, keep=fixed)  # the user's stay put
    return Completion(g, fixed, box, res.seconds)
