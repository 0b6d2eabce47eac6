"""Sampling distances of the hierarchy, adapted to the exemplar's stroke detail (seed 001
sec. 4.1.1, 4.3.5: curves are sampled at each level's spacing).

The default spacings are fixed fractions of the exemplar size (CurveConfig.deltas). Stroke art
whose strokes turn faster than the finest spacing can follow — a coastline that wiggles within
one δ, letters one or two δ tall — becomes a zigzag of samples at that spacing whose
neighbourhoods no longer describe the strokes. When the 75th percentile of the turning angle
between consecutive finest-level samples exceeds ``detail_turn`` radians, all spacings are
halved (at most ``max_halvings`` times, and only while the finest exemplar graph stays under
``max_exemplar`` samples). The neighbourhood radii keep their extent (more samples per
neighbourhood, the same context: with radii shrunk alike, the sparse map crops came out two to
three times too dense). The shipped exemplars (p75 at most 0.7 rad) keep the defaults.
"""

from __future__ import annotations

import numpy as np

from cvt.curves.fairing import chain_neighbors, turning
from cvt.curves.sampling import exemplar_graph
from cvt.curves.strokes import CurveExemplar
from cvt.sampling import Level


def detail_scale(cx: CurveExemplar, delta: float, detail_turn: float, max_halvings: int,
                 max_exemplar: int) -> float:
    """Factor (1, 1/2, 1/4, ...) on the spacings for the exemplar's stroke detail."""
    scale = 1.0
    for _ in range(max_halvings):
        g = exemplar_graph(cx, delta * scale)
        mid, nb = chain_neighbors(g)
        if mid.numel() == 0 or np.percentile(turning(g.pos, mid, nb).numpy(), 75) <= detail_turn:
            break
        if 2 * len(g) > max_exemplar:
            break
        scale /= 2
    return scale


def curve_levels(cx: CurveExemplar, cfg) -> list[Level]:
    """The hierarchy's (spacing, radius) per level, coarse first, for ``cfg`` (CurveConfig);
    finer spacings keep the default radii."""
    levels = [cfg.level(cx.exemplar.size, k) for k in range(cfg.levels)]
    if cfg.detail_turn <= 0:
        return levels
    f = detail_scale(cx, levels[-1].delta, cfg.detail_turn, cfg.max_halvings, cfg.max_exemplar)
    return [Level(lv.delta * f, lv.radius) for lv in levels]
