"""The ``cvt`` command line: ``cvt synthesize``, ``cvt inspect`` (and ``cvt autocomplete``,
cvt/cli_curves.py)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from pathlib import Path

from cvt import cli_curves
from cvt.baselines import METHODS
from cvt.limits import add_limit_arguments, limits_from
from neuraltex import __version__
from neuraltex.cli import args as types
from neuraltex.errors import InputError, OneLineParser, cli_entry, dispatch, one_line
from neuraltex.fileio import check_writable, write_bytes_atomic, write_text_atomic

MAX_SIDE_RATIO = 20.0  # output side / exemplar side
MAX_FINE_SAMPLES = 200_000  # rough cap on finest-level output samples
MAX_WEIGHT = 1e6  # energy weights (--w-f, --w-l, --w-s, --w-a)


SYNTHESIZE = """Grow an SVG exemplar (a pattern of discrete elements, or of curves) into a larger
pattern with the same arrangement: Clustered Vector Textures for elements, Continuous Curve
Textures for strokes. External references in the SVG (<image href>, CSS url) are ignored, never
read. Inputs beyond the limits below are refused with one line (raise a limit to go on)."""
INSPECT = """List an SVG exemplar's elements (after the same parsing as synthesize: groups,
background, ignored references) and its samples per hierarchy level; draw the finest level's
samples, coloured by cluster, to a PNG."""


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="cvt",
        description="Clustered Vector Textures: synthesize larger SVG patterns from an exemplar.",
    )
    parser.add_argument("--version", action="version", version=f"cvt {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    syn = sub.add_parser("synthesize", help="grow an SVG exemplar into a larger pattern",
                         description=SYNTHESIZE)
    syn.add_argument("exemplar", nargs="?", help="input SVG exemplar (or give --from-image)")
    syn.add_argument("-o", "--output", required=True, type=types.output_file(".svg"),
                     help="output SVG")
    _add_image_args(syn)
    syn.add_argument("--width", type=types.number(0, 1e7, open_lo=True),
                     help="output width in exemplar user units (with --height)")
    syn.add_argument("--height", type=types.number(0, 1e7, open_lo=True),
                     help="output height in exemplar user units (with --width)")
    syn.add_argument("--scale", type=types.number(0, MAX_SIDE_RATIO, open_lo=True),
                     help=f"output size as a multiple of the exemplar's (at most "
                     f"{MAX_SIDE_RATIO:g}; see also --max-samples)")
    syn.add_argument("--seed", type=types.seed, default=0, help="random seed (default 0)")
    syn.add_argument("--levels", type=types.integer(1, 3), default=3,
                     help="hierarchy levels, 1-3 (default 3)")
    syn.add_argument("--iterations", type=types.integer(1, 100), default=7,
                     help="iterations per level, 1-100 (default 7)")
    syn.add_argument("--init", choices=("patch", "random", "gaussian"), default="patch",
                     help="first-level output: random input patches (default), random samples, "
                     "or whole elements placed by their Gaussians (centres, covariances)")
    syn.add_argument("--method", choices=METHODS, default="full",
                     help="full (default): clustering step, filtering and depth order; "
                     "no-clustering: fixed cluster ids; spectral: spectral clustering into "
                     "|O|/|I| x |{C_i}| clusters (the paper's baseline); random: random "
                     "non-overlapping elements; no-features / no-link / no-shape: ablations "
                     "w_f = 0 / w_l = 0 / w_s = 0")
    weight = types.number(0, MAX_WEIGHT)
    syn.add_argument("--w-f", type=weight, help="shape-context weight in eq. 3 (default 10)")
    syn.add_argument("--w-l", type=weight, help="link-energy weight in eq. 9 (default 1)")
    syn.add_argument("--w-s", type=weight, help="shape-energy weight in eq. 9 (default 4)")
    syn.add_argument("--threads", type=types.integer(1, 256), default=1,
                     help="torch CPU threads (default 1)")
    _add_pattern_args(syn)
    syn.add_argument("--preview", type=types.output_file(".png"),
                     help="also render the result to this PNG")
    syn.add_argument("--debug-dir", help="write per-iteration sample pictures and energies here")
    syn.add_argument("--quiet", action="store_true", help="no progress bar")
    syn.add_argument("--max-samples", type=types.integer(1, 10**9), metavar="N",
                     help=f"largest output, in finest-level samples (default "
                     f"{MAX_FINE_SAMPLES:,} for element patterns, "
                     f"{cli_curves.MAX_OUT_SAMPLES:,} for curves)")
    cli_curves.add_curve_arguments(syn)
    add_limit_arguments(syn)
    syn.set_defaults(func=cmd_synthesize)

    ins = sub.add_parser("inspect", help="list an exemplar's elements and samples per level",
                         description=INSPECT)
    ins.add_argument("exemplar", help="input SVG exemplar")
    ins.add_argument("--png", type=types.output_file(".png"),
                     help="PNG of the sampled clusters (default: <stem>.samples.png)")
    ins.add_argument("--no-png", action="store_true", help="do not write the PNG")
    ins.add_argument("--levels", type=types.integer(1, 3), default=3,
                     help="hierarchy levels, 1-3 (default 3)")
    add_limit_arguments(ins)
    ins.set_defaults(func=cmd_inspect)
    cli_curves.add_autocomplete_command(sub)
    return parser


def _add_image_args(syn) -> None:
    """Options of ``--from-image`` (a raster image vectorized into texton elements first)."""
    from neuraltex.cli.common import add_tile_option

    img = syn.add_argument_group("from a raster image (vectorized into texton elements first)")
    img.add_argument("--from-image", metavar="IMAGE",
                     help="vectorize IMAGE (neuraltex vectorize) and use it as the exemplar; a "
                     "texture file (.ntex, neuraltex fit) gives its fitted segments")
    img.add_argument("--segmenter", default="model", choices=("model", "felzenszwalb"),
                     help="texton model (default) or the Felzenszwalb baseline")
    img.add_argument("--checkpoint", help="texton model .safetensors (default: the shipped one)")
    add_tile_option(img, "--segmenter model: ")
    img.add_argument("--max-side", type=types.integer(16, 4096), default=256,
                     help="the image is downscaled to this side first (16-4096, default 256)")
    img.add_argument("--exemplar-out", type=types.output_file(".svg"),
                     help="also write the vectorized exemplar SVG here")
    img.add_argument("--w-a", type=types.number(0, MAX_WEIGHT),
                     help="weight of the texton-kind appearance term A(s) (default 1; 0: off)")


def _add_pattern_args(syn) -> None:
    """Real-world pattern options (cvt.pattern)."""
    pat = syn.add_argument_group("real-world patterns")
    pat.add_argument("--elements", choices=("auto", "shapes", "groups"), default="auto",
                     help="what an element is: groups = the file's top-level nodes (a <g> is "
                     "one element); shapes = every drawable leaf, compound paths split; auto "
                     "(default) = groups, compound paths split, lone wrapper groups opened")
    pat.add_argument("--no-lattice", action="store_true",
                     help="do not tile near-periodic exemplars; always use the seed's method")
    pat.add_argument("--no-density", action="store_true",
                     help="do not bring each element kind to the exemplar's density")
    pat.add_argument("--clip", action="store_true",
                     help="clip elements crossing the canvas (or domain) border")
    pat.add_argument("--tileable", action="store_true",
                     help="make the output repeat seamlessly when tiled (the synthesis and the "
                     "canvas repair run on a torus: neighbourhoods wrap around); a lattice "
                     "exemplar's output size is snapped to whole periods (said on stderr)")
    pat.add_argument("--domain", metavar="SHAPE.svg",
                     help="fill the closed region of this SVG's shapes (fitted into the "
                     "output canvas) instead of the rectangle")


def _output_size(args, exemplar) -> tuple[float, float]:
    vw, vh = exemplar.viewbox[2:]
    if args.scale is not None:
        if args.width is not None or args.height is not None:
            raise InputError("give either --scale or --width/--height, not both")
        w, h = args.scale * vw, args.scale * vh
    elif args.width is not None and args.height is not None:
        w, h = args.width, args.height
    else:
        raise InputError("give the output size: --width W --height H, or --scale S")
    if not (math.isfinite(w) and math.isfinite(h)) or w <= 0 or h <= 0:
        raise InputError(f"output size must be positive, got {w:g} x {h:g}")
    small = exemplar.size / 20  # the coarsest sampling distance
    if w < small or h < small:
        raise InputError(f"output size {w:g} x {h:g} is too small (minimum {small:g} per side)")
    if w / vw > MAX_SIDE_RATIO or h / vh > MAX_SIDE_RATIO:
        raise InputError(f"output size {w:g} x {h:g} is more than {MAX_SIDE_RATIO:g}x the "
                         f"exemplar ({vw:g} x {vh:g})")
    return w, h


def _check_args(args) -> None:
    if (args.exemplar is None) == (args.from_image is None):
        raise InputError("give an exemplar SVG or --from-image IMAGE (one of the two)")
    if args.debug_dir is not None:
        debug = Path(args.debug_dir)
        if debug.exists() and not debug.is_dir():
            raise InputError(f"--debug-dir {debug}: not a folder")
        check_writable(debug / "energy.png")


def _warn(ex) -> None:
    """The parser's warnings (ignored references, dropped shapes), one line each."""
    for line in ex.warnings:
        print(f"cvt: warning: {line}", file=sys.stderr)


def _arrangeable(ex) -> None:
    if not ex.elements:
        raise InputError("the exemplar has only background content and no elements to arrange")


def cmd_synthesize(args) -> int:
    from cvt.svg import load_svg

    _check_args(args)
    image = _from_image(args) if args.from_image else None
    lim = limits_from(args)
    ex = image.exemplar if image else load_svg(args.exemplar, args.elements, lim)
    _warn(ex)
    if cli_curves.is_curves(args, ex):
        return cli_curves.synthesize_curves(args, ex)
    _arrangeable(ex)
    size = _output_size(args, ex)
    if not args.quiet and ex.note:
        print(ex.note, file=sys.stderr)

    from tqdm import tqdm

    from cvt.clustering import ClusteringParams
    from cvt.pattern import pattern_svg, synthesize_pattern
    from cvt.sampling import sample_exemplar
    from cvt.synthesis import SynthesisConfig
    weights = {k: v for k, v in (("w_l", args.w_l), ("w_s", args.w_s)) if v is not None}
    extra = {k: v for k, v in (("w_f", args.w_f), ("w_a", args.w_a)) if v is not None}
    cfg = SynthesisConfig(levels=args.levels, iterations=args.iterations, seed=args.seed,
                          init=args.init, threads=args.threads, cluster=ClusteringParams(**weights),
                          **extra)
    fine = sample_exemplar(ex, cfg.deltas[-1] * ex.size)  # cheap size guard before the work
    est = len(fine) * size[0] * size[1] / (ex.viewbox[2] * ex.viewbox[3])
    cap = args.max_samples or MAX_FINE_SAMPLES
    if est > cap:
        raise InputError(f"output too large: about {est:,.0f} finest-level samples "
                         f"(limit {cap:,}; raise it with --max-samples)")
    debug = Path(args.debug_dir) if args.debug_dir else None
    bar = tqdm(total=cfg.levels * cfg.iterations, disable=args.quiet, file=sys.stderr,
               unit="it", dynamic_ncols=True)
    box = (ex.viewbox[0], ex.viewbox[1], ex.viewbox[0] + size[0], ex.viewbox[1] + size[1])

    def on_iteration(state) -> None:
        bar.set_description(f"level {state.level + 1}/{cfg.levels}")
        bar.set_postfix(energy=f"{state.energy:.3f}", samples=len(state.samples))
        bar.update(1)
        if debug is not None:
            from cvt.debug import draw_samples

            draw_samples(state.samples.pos, state.samples.cluster, box,
                         debug / f"level{state.level}_iter{state.iteration}.png")

    opts = _pattern_options(args, box)
    if image is not None:  # a picture's segments: single elements, its lattice if any
        opts = dataclasses.replace(opts, composites=False, basis=image.lattice)
    try:
        pattern = synthesize_pattern(ex, size, cfg, args.method, opts, on_iteration)
    finally:
        bar.close()
    for note in pattern.notes:
        if not args.quiet:
            print(note, file=sys.stderr)
    text = pattern_svg(ex, pattern, opts)
    if image is not None:
        from cvt.from_textons import with_backdrop

        text = with_backdrop(text, image.backdrop)
    write_outputs(args, text, image.svg if image is not None else None)
    res = pattern.result
    if debug is not None and res is not None:
        from cvt.debug import draw_energy

        draw_energy(res.energies, debug / "energy.png")
        write_text_atomic(debug / "energy.json", json.dumps(
            {"energies": res.energies, "timings_s": res.timings,
             "samples_per_level": res.samples_per_level}, indent=1))
    if res is not None and res.energies:
        print(f"wrote {args.output}: {len(pattern.placements)} elements, "
              f"{res.samples_per_level[-1]} finest samples, energy {res.energies[-1][2]:.3f}")
    else:
        print(f"wrote {args.output}: {len(pattern.placements)} elements")
    return 0


def _pattern_options(args, box):
    from cvt.domain import Domain
    from cvt.pattern import PatternOptions

    domain = Domain.from_svg(args.domain, limits_from(args)).fitted(box) if args.domain else None
    return PatternOptions(lattice=not args.no_lattice, density=not args.no_density,
                          tileable=args.tileable, domain=domain, clip=args.clip)


def _from_image(args):
    """Vectorize --from-image into an exemplar (and write it to --exemplar-out)."""
    from cvt.from_textons import image_exemplar, vectorize_picture
    from neuraltex.model import DEFAULT_MODEL

    checkpoint = args.checkpoint
    if args.segmenter == "model" and not checkpoint:
        if not DEFAULT_MODEL.exists():
            raise InputError("no default texton model is shipped yet; pass --checkpoint "
                             "MODEL.safetensors or --segmenter felzenszwalb")
        checkpoint = DEFAULT_MODEL
    svg, picture = vectorize_picture(args.from_image, args.segmenter, checkpoint,
                                     max_side=args.max_side, tile=args.tile)
    image = image_exemplar(svg)  # --exemplar-out is written with the output (write_outputs)
    if not args.no_lattice:  # a picture that repeats a tile keeps its lattice
        from neuraltex.raster_lattice import raster_lattice

        image.lattice = raster_lattice(picture)
    if not args.quiet:
        print(f"vectorized {args.from_image}: {len(image.exemplar.elements)} elements",
              file=sys.stderr)
    return image


def write_outputs(args, text: str, exemplar: str | None = None) -> None:
    """Write the output SVG ``text``, with ``--preview`` its render (cvt.raster: external
    references never followed, bounded size) and with ``--exemplar-out`` the vectorized
    ``exemplar``. The preview is rendered first, so a failure leaves no output at all."""
    from cvt.raster import png_bytes

    png = None
    if args.preview:
        try:
            png = png_bytes(text)
        except ValueError as exc:
            raise InputError(f"cannot render the preview {args.preview}: {one_line(exc)}"
                             ) from None
    write_text_atomic(args.output, text)
    if png is not None:
        write_bytes_atomic(args.preview, png)
    if exemplar is not None and getattr(args, "exemplar_out", None):
        write_text_atomic(args.exemplar_out, exemplar)


def cmd_inspect(args) -> int:
    from cvt.debug import draw_samples
    from cvt.sampling import hierarchy, sample_exemplar
    from cvt.svg import load_svg

    png = None
    if not args.no_png:
        png = Path(args.png) if args.png else Path(f"{Path(args.exemplar).stem}.samples.png")
        check_writable(png)
    ex = load_svg(args.exemplar, limits=limits_from(args))
    _warn(ex)
    _arrangeable(ex)
    x, y, w, h = ex.viewbox
    print(f"{args.exemplar}: viewBox {x:g} {y:g} {w:g} {h:g}, size {ex.size:g}, "
          f"{len(ex.elements)} elements, {len(ex.defs)} defs")
    for e in ex.elements:
        b = e.bbox
        tag = e.node.tag.rsplit("}", 1)[-1]
        print(f"  #{e.index:<4d} <{tag}> {len(e.shapes)} shape(s), "
              f"{b[2] - b[0]:.1f} x {b[3] - b[1]:.1f} at ({b[0]:.1f}, {b[1]:.1f})")
    levels = hierarchy(ex.size, args.levels)
    last = None
    for k, lv in enumerate(levels):
        last = sample_exemplar(ex, lv.delta, seed=k)
        print(f"  level {k}: delta {lv.delta:.3g}, radius {lv.radius:.3g}, {len(last)} samples")
    if png is not None:
        draw_samples(last.pos, last.cluster, (x, y, x + w, y + h), png)
        print(f"wrote {png}")
    return 0


@cli_entry("cvt")
def main(argv: list[str] | None = None) -> int:
    return dispatch(build_parser(), argv)


if __name__ == "__main__":
    raise SystemExit(main())
