"""A pattern from an exemplar, end to end: lattice or the seed's method, then the canvas.

1. A near-periodic exemplar keeps its lattice (cvt.lattice): the cell's motifs are tiled.
   Everything else goes to the seed's synthesis (``method``, cvt.baselines).
2. The canvas (cvt.canvas): fragments only where the border cuts them, nothing entirely off
   the canvas or the domain, each kind at the exemplar's density.
3. ``tileable``: the seed's method runs on a torus (cvt.torus: toroidal neighbourhoods,
   search, assignment and clustering), the canvas repair wraps around too, and the result is
   drawn periodically (cvt.tileable).

The background (cvt.background) is drawn under it all by :func:`pattern_svg`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from cvt.baselines import run_method
from cvt.canvas import (
    composites,
    drop_overlaps,
    keep_on_canvas,
    kind_rates,
    overlap_limits,
    repair_density,
)
from cvt.companions import companion_kinds, drop_orphans
from cvt.density import fragment_owners
from cvt.domain import Domain
from cvt.kinds import cut_mask, element_kinds, exact_kinds
from cvt.lattice import detect_lattice, lattice_copies
from cvt.reconstruction import Placement
from cvt.svg import Exemplar, to_svg
from cvt.synthesis import SynthesisConfig, SynthesisResult
from cvt.tileable import wrap_around, wrap_centres
from cvt.torus import Torus


@dataclass(frozen=True)
class PatternOptions:
    lattice: bool = True  # tile the cell of near-periodic exemplars
    density: bool = True  # bring each kind to the exemplar's density
    tileable: bool = False  # output repeats seamlessly
    domain: Domain | None = None  # fill this region (already fitted to the canvas)
    clip: bool = False  # clip elements crossing the canvas (or domain) border
    # Element kinds (E,) given by the caller (e.g. texton kinds, neuraltex.texton_synthesis);
    # the density repair then adds and removes single elements, not composites. None: kinds
    # from the markup (cvt.kinds.element_kinds).
    kinds: np.ndarray | None = None


@dataclass
class Pattern:
    placements: list[tuple[int, float, float]]  # (element, dx, dy), bottom to top
    size: tuple[float, float]
    notes: list[str]
    result: SynthesisResult | None = None  # the seed's synthesis, when it ran
    lattice: object | None = None


def synthesize_pattern(ex: Exemplar, size: tuple[float, float], cfg: SynthesisConfig,
                       method: str = "full", opts: PatternOptions = PatternOptions(),
                       on_iteration=None) -> Pattern:
    vx, vy = ex.viewbox[:2]
    out_box = (vx, vy, vx + size[0], vy + size[1])
    boxes = np.stack([e.bbox for e in ex.elements])  # (E, 4)
    cut = cut_mask(ex.elements, ex.viewbox)
    notes = []
    if cut.all():  # nothing whole to copy: the cut pieces are all the exemplar has
        cut[:] = False
        notes.append("every element is cut by the border: pieces used as elements")
    kinds = element_kinds(ex.elements, cut) if opts.kinds is None else np.asarray(opts.kinds)
    if method == "random":
        res = run_method(method, ex, size, cfg)
        return Pattern(_placed(res), size, notes, res)
    placed, res, lat = _arrange(ex, size, cfg, method, opts, boxes, cut, kinds, notes,
                                on_iteration)
    inside = opts.domain.contains if opts.domain is not None else None
    torus = Torus.of(out_box) if opts.tileable else None
    if torus is not None:  # no border to cut fragments on a torus
        placed = wrap_centres([p for p in placed if not cut[p[0]]], boxes, out_box)
    placed = keep_on_canvas(placed, boxes, cut, out_box, inside)
    if opts.density and (lat is None or opts.domain is not None or opts.tileable):
        area = opts.domain.area if opts.domain is not None else size[0] * size[1]
        groups = composites(boxes, cut) if opts.kinds is None else [[e] for e in range(len(kinds))]
        placed = _repair(placed, ex, boxes, cut, kinds, groups, out_box, area, cfg.seed, inside,
                         torus)
    if opts.tileable:
        placed = wrap_around(placed, boxes, out_box)
    return Pattern(placed, size, notes, res, lat)


def _arrange(ex, size, cfg, method, opts, boxes, cut, kinds, notes, on_iteration):
    """Placements from the lattice, the seed's method, or none. Returns (placed, result,
    lattice) and appends what it did to ``notes``."""
    vx, vy = ex.viewbox[:2]
    lat = None
    if opts.lattice:
        centers = (boxes[:, :2] + boxes[:, 2:]) / 2
        # translated copies first (mirrored rows are two motifs), then copies of a kind
        lat = (detect_lattice(centers, exact_kinds(ex.elements, kinds), boxes, ~cut, ex.viewbox)
               or detect_lattice(centers, kinds, boxes, ~cut, ex.viewbox))
    if lat is not None:
        notes.append(f"lattice: periods ({lat.a[0]:.4g}, {lat.a[1]:.4g}) and ({lat.b[0]:.4g}, "
                     f"{lat.b[1]:.4g}), {len(lat.reps)} motif(s) per cell, explains "
                     f"{lat.explained:.0%} of the exemplar")
        return lattice_copies(lat, boxes, (vx, vy, vx + size[0], vy + size[1])), None, lat
    if (~cut).sum() >= 2:
        cfg = dataclasses.replace(cfg, tileable=opts.tileable)
        res = run_method(method, ex, size, cfg, on_iteration)
        notes.append(f"no lattice: {method} synthesis" + (" on a torus" if opts.tileable else ""))
        return _placed(res), res, None
    notes.append("fewer than two whole elements: placed at the exemplar's density")
    return [], None, None


def _repair(placed, ex, boxes, cut, kinds, groups, out_box, area, seed, inside, torus=None):
    """No clashes the exemplar never shows, companions paired, each kind at its density (on a
    ``torus``: across the seam too)."""
    rates = kind_rates(boxes, kinds, cut, ex.viewbox,
                       fragment_owners(ex.elements, kinds, cut, ex.viewbox))
    pairs = companion_kinds(boxes, kinds, cut)
    placed = drop_overlaps(placed, boxes, kinds, overlap_limits(boxes, kinds, cut), torus)
    rng = np.random.default_rng(seed)
    placed = drop_orphans(placed, boxes, kinds, pairs, torus)  # re-added whole by the repair
    placed = repair_density(placed, boxes, kinds, rates, groups, out_box, area, rng, inside,
                            torus, pairs)
    return placed


def _placed(res: SynthesisResult) -> list[tuple[int, float, float]]:
    return [(p.element, p.dx, p.dy) for p in res.placements]


def as_result(pattern: Pattern) -> SynthesisResult:
    """The pattern as a SynthesisResult (for code that reads placements from one)."""
    res = pattern.result or SynthesisResult([], pattern.size, [], [])
    pls = [Placement(k, e, dx, dy, 0.0, e) for k, (e, dx, dy) in enumerate(pattern.placements)]
    return dataclasses.replace(res, placements=pls)


def pattern_svg(ex: Exemplar, pattern: Pattern, opts: PatternOptions = PatternOptions()) -> str:
    """SVG text: the background over the output canvas, then the placed elements."""
    from cvt.background import backdrop_nodes

    vx, vy = ex.viewbox[:2]
    out_box = (vx, vy, vx + pattern.size[0], vy + pattern.size[1])
    if opts.domain is not None:
        clip = opts.domain.svg_path()
    else:
        x0, y0, x1, y1 = out_box
        clip = f"M{x0:.6g},{y0:.6g} H{x1:.6g} V{y1:.6g} H{x0:.6g} Z" if opts.clip else None
    return to_svg(ex, pattern.placements, pattern.size, backdrop_nodes(ex, out_box), clip,
                  opts.clip)
