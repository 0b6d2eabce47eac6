"""``cvt`` command line for curve patterns: ``cvt synthesize --kind curves|auto`` and
``cvt autocomplete`` (seed 001). Wired into cvt/cli.py by a few lines."""

from __future__ import annotations

import argparse
import math
import sys
import time

from cvt.limits import add_limit_arguments, limits_from
from neuraltex.cli import args as types
from neuraltex.errors import InputError

KINDS = ("auto", "curves", "elements")
CURVE_METHODS = {"full": "ours", "random": "random"}  # cvt --method -> cvt.curves method
MAX_OUT_SAMPLES = 50_000
MAX_REGION_AREA = 25  # autocomplete region / exemplar area
AUTOCOMPLETE = """Predict the strokes around a partial drawing so they continue a curve exemplar
(the backend of an interactive editor): the drawing is kept, strokes are added in a margin
around it (or in --region), at most {area}x the exemplar's area."""


def add_curve_arguments(syn: argparse.ArgumentParser) -> None:
    """``--kind`` (and ``--domain`` unless the parser has it already) for ``cvt synthesize``."""
    syn.add_argument("--kind", choices=KINDS, default="auto",
                     help="curves: connected strokes (Continuous Curve Textures); elements: "
                     "discrete elements (Clustered Vector Textures); auto (default): curves when "
                     "unfilled strokes join, cross or run longer than a third of the exemplar")
    try:
        syn.add_argument("--domain", metavar="SHAPE.svg",
                         help="fill only the inside of this SVG's filled shapes (curves)")
    except argparse.ArgumentError:
        pass  # another module already offers --domain


def is_curves(args, exemplar) -> bool:
    """Whether ``cvt synthesize`` should run the curve synthesis."""
    from cvt.curves.strokes import looks_like_curves

    kind = getattr(args, "kind", "auto")
    if kind == "auto":
        return getattr(args, "from_image", None) is None and looks_like_curves(exemplar)
    return kind == "curves"


def domain_inside(path, limits):
    """Predicate (N, 2) -> (N,) bool: inside any filled shape of the SVG at ``path``."""
    import numpy as np
    import torch

    from cvt.sampling import _inside
    from cvt.svg import load_svg

    ex = load_svg(path, limits=limits)
    # a shape that covers most of the canvas is split off as background by the parser: it
    # is still the domain
    shapes = [s for e in ex.elements + ex.background for s in e.shapes if s.filled]
    if not shapes:
        raise InputError(f"{path}: the domain SVG has no filled shape")

    def inside(p: torch.Tensor) -> torch.Tensor:
        pts = p.numpy()
        ok = np.zeros(len(pts), dtype=bool)
        for s in shapes:
            ok |= _inside(pts, s)
        return torch.from_numpy(ok)

    return inside


def synthesize_curves(args, exemplar) -> int:
    """``cvt synthesize`` for a curve exemplar (already parsed, ``exemplar``)."""
    from cvt.cli import _output_size, write_outputs
    from cvt.curves.baselines import run_curves
    from cvt.curves.reconstruction import curves_svg
    from cvt.curves.sampling import exemplar_graph
    from cvt.curves.spacing import curve_levels
    from cvt.curves.strokes import curve_exemplar
    from cvt.curves.synthesis import CurveConfig

    if args.method not in CURVE_METHODS:
        raise InputError(f"--method {args.method} is for element patterns; curve patterns "
                         f"take {' or '.join(CURVE_METHODS)}")
    element_only = {"--debug-dir": args.debug_dir, "--w-f": args.w_f, "--w-l": args.w_l,
                    "--w-s": args.w_s, "--w-a": args.w_a,
                    "--init": None if args.init == "patch" else args.init}
    given = [k for k, v in element_only.items() if v is not None]
    if given:
        raise InputError(f"{', '.join(given)}: element-pattern options; this exemplar is "
                         "synthesized as curves (use --kind elements for the element synthesis)")
    cx = curve_exemplar(exemplar)
    size = _output_size(args, exemplar)
    cfg = CurveConfig(levels=args.levels, iterations=args.iterations, seed=args.seed,
                      threads=args.threads)
    fine = len(exemplar_graph(cx, curve_levels(cx, cfg)[-1].delta))  # as synthesized
    est = fine * size[0] * size[1] / (exemplar.viewbox[2] * exemplar.viewbox[3])
    cap = getattr(args, "max_samples", None) or MAX_OUT_SAMPLES
    if est > cap:
        raise InputError(f"output too large: about {est:,.0f} curve samples "
                         f"(limit {cap:,}; raise it with --max-samples)")
    domain = getattr(args, "domain", None)
    inside = domain_inside(domain, limits_from(args)) if isinstance(domain, str) else None
    t = time.perf_counter()
    g, _ = run_curves(CURVE_METHODS[args.method], cx, size, cfg, inside)
    write_outputs(args, curves_svg(exemplar, cx.element_centers(), g, size))
    print(f"wrote {args.output}: curves, {len(g)} samples, {len(g.edges)} edges "
          f"({time.perf_counter() - t:.1f} s)")
    return 0


def add_autocomplete_command(sub) -> None:
    """Register ``cvt autocomplete``."""
    ac = sub.add_parser("autocomplete", help="predict the strokes around a partial drawing "
                        "from a curve exemplar (interactive-editor backend)",
                        description=AUTOCOMPLETE.format(area=MAX_REGION_AREA))
    ac.add_argument("partial", help="SVG of what has been drawn so far (its canvas = viewBox)")
    ac.add_argument("--exemplar", required=True, help="curve exemplar SVG to imitate")
    ac.add_argument("-o", "--output", required=True, type=types.output_file(".svg"),
                    help="output SVG on the partial's canvas")
    ac.add_argument("--margin", type=types.number(0, 1e7, open_lo=True),
                    help="predict this far around the drawing, in user units (default: a "
                    "quarter of the exemplar size)")
    ac.add_argument("--region", type=types.number(-1e7, 1e7), nargs=4,
                    metavar=("X", "Y", "W", "H"), help="predict inside this rectangle instead")
    ac.add_argument("--only-new", action="store_true",
                    help="write only the predicted strokes, not the drawing")
    ac.add_argument("--levels", type=types.integer(1, 3), default=2,
                    help="hierarchy levels, 1-3 (default 2)")
    ac.add_argument("--iterations", type=types.integer(1, 100), default=7,
                    help="iterations per level, 1-100 (default 7)")
    ac.add_argument("--seed", type=types.seed, default=0, help="random seed (default 0)")
    ac.add_argument("--preview", type=types.output_file(".png"),
                    help="also render the result to this PNG")
    add_limit_arguments(ac)
    ac.set_defaults(func=cmd_autocomplete)


def _region(args, partial, cx):
    from cvt.curves.autocomplete import region_around

    if args.region is not None:
        x, y, w, h = args.region
        if w <= 0 or h <= 0:
            raise InputError("--region needs a positive width W and height H")
        return (x, y, x + w, y + h)
    margin = cx.exemplar.size / 4 if args.margin is None else args.margin
    if not (math.isfinite(margin) and margin > 0):
        raise InputError("--margin must be a positive number")
    return region_around(partial, margin)


def cmd_autocomplete(args) -> int:
    from dataclasses import replace

    from cvt.cli import write_outputs
    from cvt.curves.autocomplete import autocomplete
    from cvt.curves.reconstruction import curves_svg
    from cvt.curves.strokes import load_curves
    from cvt.curves.synthesis import CurveConfig

    lim = limits_from(args)
    cx = load_curves(args.exemplar, lim)
    partial = load_curves(args.partial, lim)
    box = _region(args, partial, cx)
    area = cx.exemplar.viewbox[2] * cx.exemplar.viewbox[3]
    if (box[2] - box[0]) * (box[3] - box[1]) > MAX_REGION_AREA * area:
        raise InputError(f"the region to complete is more than {MAX_REGION_AREA}x the "
                         "exemplar's area")
    res = autocomplete(cx, partial, box, CurveConfig(levels=args.levels,
                                                     iterations=args.iterations, seed=args.seed))
    x, y, w, h = partial.exemplar.viewbox
    canvas = replace(cx.exemplar, viewbox=(x, y, w, h), unit_scale=partial.exemplar.unit_scale)
    text = curves_svg(canvas, cx.element_centers(), res.predicted(), (w, h))
    if not args.only_new:  # the drawing itself, verbatim, under the prediction
        drawing = "\n".join(e.markup for e in partial.exemplar.elements)
        cut = text.index('<g id="curves">')
        text = text[:cut] + drawing + "\n" + text[cut:]
    write_outputs(args, text)
    n_new = len(res.graph) - res.n_fixed
    print(f"wrote {args.output}: {n_new} predicted samples around {res.n_fixed} drawn "
          f"({res.seconds:.2f} s)", file=sys.stdout)
    return 0
