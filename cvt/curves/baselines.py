"""The two comparison methods of scripts/eval_curves.py, and ours, behind one call.

* ``ours``: cvt.curves.synthesis with connectivity (eq. 5 in the search, eqs. 17-22 edges).
* ``no-connectivity``: the same synthesis of samples without the edge term or edge
  assignment; after every assignment step each sample is joined to its nearest samples. The
  issue's baseline is this reconnection as it stands (``CurveRun.plain``: redrawn and faired,
  no pruning, no end repair toward the exemplar); with the whole ``finish`` it is a stronger
  one (``CurveRun.final``), reported beside it.
* ``random``: random exemplar pieces (patches of side 2r with their edges) on a grid, i.e. the
  initialization alone.

``final`` is every method's output after the same clean-up (``finish``: cvt.curves.cleanup,
cvt.curves.fairing); ours is what a user gets.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import torch

from cvt.curves.cleanup import prune, repair_ends
from cvt.curves.domain import Inside
from cvt.curves.fairing import fair_like
from cvt.curves.graph import CurveGraph
from cvt.curves.init import box_inside, patch_init
from cvt.curves.sampling import exemplar_graph
from cvt.curves.strokes import CurveExemplar
from cvt.curves.synthesis import CurveConfig, synthesize_curves, upsample

METHODS = ("ours", "no-connectivity", "random")


@dataclass
class CurveRun:
    """One method's output before the end repair (``raw``: the synthesized graph redrawn at
    ``delta``, nothing pruned, joined or removed), the same only faired (``plain``: no pruning,
    no end repair) and after the whole ``finish`` (``final``: what the user gets)."""

    raw: CurveGraph
    plain: CurveGraph
    final: CurveGraph
    delta: float


def run_curves(method: str, cx: CurveExemplar, size: tuple[float, float], cfg: CurveConfig,
               inside: Inside | None = None) -> tuple[CurveGraph, float]:
    """The final (pruned) output graph of ``method`` and the finest sampling distance."""
    run = run_staged(method, cx, size, cfg, inside)
    return run.final, run.delta


def run_staged(method: str, cx: CurveExemplar, size: tuple[float, float], cfg: CurveConfig,
               inside: Inside | None = None) -> CurveRun:
    """``method``'s output before and after the shared finish."""
    x0, y0, _, _ = cx.box
    box = (x0, y0, x0 + size[0], y0 + size[1])
    if method == "random":
        lv = cfg.level(cx.exemplar.size, cfg.levels - 1)
        inp = exemplar_graph(cx, lv.delta)
        gen = torch.Generator().manual_seed(cfg.seed)
        out = patch_init(inp, cx.box, box, 2 * cfg.level(cx.exemplar.size, 0).radius,
                         box_inside(box, inside), gen)
        delta = lv.delta
    else:
        if method == "no-connectivity":
            cfg = replace(cfg, w_edge=0.0, connectivity=False)
        elif method != "ours":
            raise ValueError(f"method must be one of {METHODS}")
        res = synthesize_curves(cx, size, cfg, inside)
        out, inp, delta = res.graph, res.inputs[-1], res.delta
    raw = upsample(out, delta)
    return CurveRun(raw, fair_like(raw, inp, cx.box, box, delta),
                    finish(raw, inp, cx.box, box, delta, inside), delta)


def finish(raw: CurveGraph, inp: CurveGraph, in_box, out_box, delta: float,
           inside: Inside | None = None) -> CurveGraph:
    """The clean-up every method gets, on its output redrawn as its SVG will read (``raw``:
    paths re-sampled at ``delta``, crossings and touching ends joined, like the exemplar):
    stroke spurs / specks pruned and stroke ends repaired to the exemplar's, strokes faired.
    With a domain shape ``inside``, ends at its border are the border's cut (like the
    canvas'), and what the fairing moved out of it is clipped."""
    region = out_box if inside is None else box_inside(out_box, inside)
    g = prune(raw, inp, in_box, region, delta)
    g = repair_ends(g, inp, in_box, region, delta)
    g = fair_like(g, inp, in_box, out_box, delta)
    if inside is None:
        return g
    return g.select(torch.nonzero(region(g.pos)).flatten())
