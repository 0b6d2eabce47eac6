"""The two comparison methods of scripts/eval_curves.py, and ours, behind one call.

* ``ours``: cvt.curves.synthesis with connectivity (eq. 5 in the search, eqs. 17-22 edges).
* ``no-connectivity``: the same synthesis of samples without the edge term or edge
  assignment; after every assignment step each sample is joined to its nearest samples.
* ``random``: random exemplar pieces (patches of side 2r with their edges) on a grid, i.e. the
  initialization alone.

All three get the same clean-up (cvt.curves.cleanup) and reconstruction.
"""

from __future__ import annotations

from dataclasses import replace

import torch

from cvt.curves.cleanup import join_ends, prune
from cvt.curves.fairing import fair_like
from cvt.curves.graph import CurveGraph
from cvt.curves.init import box_inside, patch_init
from cvt.curves.sampling import exemplar_graph
from cvt.curves.strokes import CurveExemplar
from cvt.curves.synthesis import CurveConfig, Inside, synthesize_curves

METHODS = ("ours", "no-connectivity", "random")


def run_curves(method: str, cx: CurveExemplar, size: tuple[float, float], cfg: CurveConfig,
               inside: Inside | None = None) -> tuple[CurveGraph, float]:
    """The final (pruned) output graph of ``method`` and the finest sampling distance."""
    x0, y0, _, _ = cx.box
    box = (x0, y0, x0 + size[0], y0 + size[1])
    if method == "random":
        lv = cfg.level(cx.exemplar.size, cfg.levels - 1)
        inp = exemplar_graph(cx, lv.delta)
        gen = torch.Generator().manual_seed(cfg.seed)
        out = patch_init(inp, cx.box, box, 2 * cfg.level(cx.exemplar.size, 0).radius,
                         box_inside(box, inside), gen)
        out = prune(out, inp, cx.box, box, lv.delta)
        return fair_like(out, inp, cx.box, box, lv.delta), lv.delta
    if method == "no-connectivity":
        cfg = replace(cfg, w_edge=0.0, connectivity=False)
    elif method != "ours":
        raise ValueError(f"method must be one of {METHODS}")
    res = synthesize_curves(cx, size, cfg, inside)
    g = join_ends(res.graph, res.inputs[-1], cx.box, box, res.delta)
    g = prune(g, res.inputs[-1], cx.box, box, res.delta)
    return fair_like(g, res.inputs[-1], cx.box, box, res.delta), res.delta
