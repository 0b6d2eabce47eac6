"""A pattern from an exemplar, end to end: lattice or the seed's method, then the canvas.

1. A near-periodic exemplar keeps its lattice (cvt.lattice): the cell's motifs are tiled.
   Everything else goes to the seed's synthesis (``method``, cvt.baselines).
2. The canvas (cvt.canvas): fragments only where the border cuts them, nothing entirely off
   the canvas or the domain, each kind at the exemplar's density.
3. ``tileable``: the seed's method runs on a torus (cvt.torus: toroidal neighbourhoods,
   search, assignment and clustering), the canvas repair wraps around too, and the result is
   drawn periodically (cvt.tileable). A lattice is tiled on the nearest canvas of whole
   periods instead (cvt.lattice.axis_periods; the size change is noted).

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
from cvt.lattice import (
    AXIS_CELLS,
    Lattice,
    axis_periods,
    cell_copies,
    detect_lattice,
    lattice_copies,
    whole_periods,
)
from cvt.reconstruction import Placement
from cvt.svg import Exemplar, to_svg
from cvt.synthesis import SynthesisConfig, SynthesisResult
from cvt.tileable import wrap_around, wrap_centres
from cvt.torus import Torus
from neuraltex.errors import InputError


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
    # The density repair adds and removes composites (cvt.canvas.composites: elements sitting
    # on each other, a heart with its butterfly). False: single elements, for an exemplar whose
    # elements partition a picture (a vectorized image's segments touch, their boxes overlap,
    # and chained into composites a brick wall's 117 bricks were one group of 115).
    composites: bool = True
    # A lattice found by the caller, rows a, b in exemplar units (e.g. on the picture an
    # exemplar was vectorized from: neuraltex.raster_lattice), whose elements' kinds are too
    # fine to repeat exactly: its cells are tiled (cvt.lattice.cell_copies) instead of
    # detect_lattice's motifs. None: detect the lattice on the elements.
    basis: np.ndarray | None = None


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
    if opts.lattice and opts.basis is not None and opts.domain is None:
        cells = _cell_pattern(ex, size, opts, boxes, cut, cfg.seed, notes)
        if cells is not None:
            return cells
    lat = _lattice(ex, boxes, cut, kinds) if opts.lattice else None
    if lat is not None:
        notes.append(f"lattice: periods ({lat.a[0]:.4g}, {lat.a[1]:.4g}) and ({lat.b[0]:.4g}, "
                     f"{lat.b[1]:.4g}), {len(lat.reps)} motif(s) per cell, explains "
                     f"{lat.explained:.0%} of the exemplar")
    if lat is not None and opts.tileable:  # the tile must hold whole periods
        lat, size = _lattice_tile(lat, size, notes)
        out_box = (vx, vy, vx + size[0], vy + size[1])
    placed, res = _arrange(ex, size, cfg, method, opts, lat, boxes, cut, notes, on_iteration)
    inside = opts.domain.contains if opts.domain is not None else None
    # a lattice on whole periods is periodic already (cvt.lattice.axis_periods); wrapping its
    # copies would draw the ones crossing the seam over their neighbours there
    torus = Torus.of(out_box) if opts.tileable and lat is None else None
    if torus is not None:  # no border to cut fragments on a torus
        placed = wrap_centres([p for p in placed if not cut[p[0]]], boxes, out_box)
    placed = keep_on_canvas(placed, boxes, cut, out_box, inside)
    if opts.density and (lat is None or opts.domain is not None):
        area = opts.domain.area if opts.domain is not None else size[0] * size[1]
        groups = (composites(boxes, cut) if opts.kinds is None and opts.composites
                  else [[e] for e in range(len(kinds))])
        placed = _repair(placed, ex, boxes, cut, kinds, groups, out_box, area, cfg.seed, inside,
                         torus)
    if torus is not None:
        placed = wrap_around(placed, boxes, out_box)
    return Pattern(placed, size, notes, res, lat)


def _cell_pattern(ex, size, opts: PatternOptions, boxes, cut, seed: int,
                  notes: list[str]) -> Pattern | None:
    """The output tiled with the cells of the caller's lattice ``opts.basis``, each copying the
    whole elements centred in a random whole cell of the exemplar (cvt.lattice.cell_copies);
    tileable: the size snapped to whole periods first (:func:`_lattice_tile`). None when the
    exemplar holds no whole cell."""
    lat = Lattice.given(opts.basis)
    if opts.tileable:
        lat, size = _lattice_tile(lat, size, notes)
    vx, vy, w, h = ex.viewbox
    whole = np.nonzero(~cut)[0]
    centers = (boxes[whole, :2] + boxes[whole, 2:]) / 2
    copies = cell_copies(np.stack([lat.a, lat.b]), centers, boxes[whole], (vx, vy, vx + w, vy + h),
                         (vx, vy, vx + size[0], vy + size[1]), np.random.default_rng(seed),
                         size if opts.tileable else None)
    if copies is None:
        notes.append("lattice of the picture: no whole cell in the exemplar; arranged freely")
        return None
    notes.append(f"lattice of the picture: periods ({lat.a[0]:.4g}, {lat.a[1]:.4g}) and "
                 f"({lat.b[0]:.4g}, {lat.b[1]:.4g}); each cell copied from a random whole cell")
    return Pattern([(int(whole[e]), dx, dy) for e, dx, dy in copies], size, notes, None, lat)


def _lattice(ex, boxes, cut, kinds) -> Lattice | None:
    """The exemplar's lattice (cvt.lattice): translated copies first (mirrored rows are two
    motifs), then copies of a kind."""
    centers = (boxes[:, :2] + boxes[:, 2:]) / 2
    return (detect_lattice(centers, exact_kinds(ex.elements, kinds), boxes, ~cut, ex.viewbox)
            or detect_lattice(centers, kinds, boxes, ~cut, ex.viewbox))


def _lattice_tile(lat: Lattice, size, notes) -> tuple[Lattice, tuple[float, float]]:
    """A tileable lattice output: the lattice made exact along the canvas axes and ``size``
    snapped to the nearest whole number of its periods (said in ``notes``), so the tiling
    has no step at the seam; InputError when the lattice has no period along an axis."""
    fit = axis_periods(lat)
    if fit is None:
        raise InputError(f"--tileable: the exemplar's lattice (periods ({lat.a[0]:.4g}, "
                         f"{lat.a[1]:.4g}) and ({lat.b[0]:.4g}, {lat.b[1]:.4g})) repeats along "
                         f"no canvas axis within {AXIS_CELLS} cells; use --no-lattice")
    lat, period = fit
    snapped = whole_periods(size, period)
    if not np.allclose(snapped, size, rtol=1e-9, atol=0):
        notes.append(f"tileable lattice: output size {size[0]:.6g} x {size[1]:.6g} snapped to "
                     f"{snapped[0]:.6g} x {snapped[1]:.6g} (whole periods {period[0]:.6g} x "
                     f"{period[1]:.6g})")
    return lat, snapped


def _arrange(ex, size, cfg, method, opts, lat, boxes, cut, notes, on_iteration):
    """Placements from the lattice ``lat``, the seed's method, or none. Returns (placed,
    result) and appends what it did to ``notes``."""
    vx, vy = ex.viewbox[:2]
    out_box = (vx, vy, vx + size[0], vy + size[1])
    if lat is not None:
        return lattice_copies(lat, boxes, out_box), None
    if (~cut).sum() >= 2:
        cfg = dataclasses.replace(cfg, tileable=opts.tileable)
        res = run_method(method, ex, size, cfg, on_iteration)
        notes.append(f"no lattice: {method} synthesis" + (" on a torus" if opts.tileable else ""))
        return _placed(res), res
    notes.append("fewer than two whole elements: placed at the exemplar's density")
    return [], None


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
