"""The ``neuraltex synthesize`` subcommand: a bigger (or tileable) picture of a texture, its
textons arranged by cvt's engine (:mod:`neuraltex.texton_synthesis`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from neuraltex.cli import args as types
from neuraltex.cli import common
from neuraltex.cores import usable_cores
from neuraltex.errors import InputError

MAX_SCALE = 8.0  # output side / input side
MIN_SIDE = 16  # output pixels


def cmd_synthesize(args: argparse.Namespace) -> int:
    """Grow a texture: its textons (of an image, or of a texture file from ``neuraltex fit``,
    decoded with its tuned decoder) are arranged on a larger canvas by cvt's synthesis, as
    Gaussian elements (the textons of one object together, or one by one: whichever covers
    the canvas like the input) with their size and colour, and decoded at the output size;
    then each placed element brings pixels under its footprint (its segments and a margin
    of ground): those of the picture itself when it is at hand (an image, or a texture
    file's --source), else those of the texture's reconstruction. With --tileable the
    arrangement wraps around, and so do the decode and the pasted pixels."""
    import torch

    before = torch.get_num_threads()  # --threads for this command only (in-process callers)
    torch.set_num_threads(args.threads)
    try:
        return _run(args)
    finally:
        torch.set_num_threads(before)


def _run(args: argparse.Namespace) -> int:
    from neuraltex.imageio import check_output_path

    check_output_path(args.output)
    if args.preview_textons is not None:
        _check_svg(args.preview_textons)
    model = common.load(args.checkpoint, args.device, args.seed)
    tex = common.textons_of(model, args.texture, common.limits(args), args.device,
                            args.tile)
    decoder, (textons,) = common.decoder_for(model, tex)
    size = _size(args, textons.canvas, tex.short)
    source = _source(args, tex)
    image, arr = _synthesize(args, decoder, textons, size, tex.short, _labels(tex, args),
                             source)
    common.save(image, args.output)
    if args.preview_textons is not None:
        _write_svg(arr, args.preview_textons, size, tex.short)
    return 0


def _size(args: argparse.Namespace, canvas: tuple[float, float], short: int) -> tuple[int, int]:
    """(H, W) of the output from --size H W or --scale S (pixels of the input: canvas * short)."""
    h_in, w_in = canvas[1] * short, canvas[0] * short
    if (args.size is None) == (args.scale is None):
        raise InputError("give the output size: --size H W or --scale S (one of the two)")
    if args.size is not None:
        h, w = args.size
    else:
        h, w = round(args.scale * h_in), round(args.scale * w_in)
    if min(h, w) < MIN_SIDE:
        raise InputError(f"output {h}x{w} is too small (at least {MIN_SIDE} px a side)")
    if max(h / h_in, w / w_in) > MAX_SCALE:
        raise InputError(f"output {h}x{w} is more than {MAX_SCALE:g}x the input "
                         f"({round(h_in)}x{round(w_in)}) on a side")
    return common.limits(args).check_output(h, w)


def _labels(tex: common.Texture, args: argparse.Namespace):
    """(h, w) texton of each pixel of the texture: a texture file's segments, an image's
    most likely mask; None with --decode-only."""
    if args.decode_only:
        return None
    if tex.labels is not None:
        return tex.labels
    return None if tex.masks is None else tex.masks.argmax(0).cpu().numpy()


def _source(args: argparse.Namespace, tex: common.Texture):
    """(3, h, w) the picture whose pixels the placed elements bring: an image input itself,
    or a texture file's --source, checked against the sha256 its header records; None (the
    reconstruction's pixels) for a texture file without --source, or with --decode-only."""
    if args.source is None:
        return None if args.decode_only else tex.image
    if args.decode_only and tex.header is not None:
        raise InputError("--source and --decode-only exclude each other (--decode-only "
                         "pastes no pixels)")
    return common.source_picture(args.source, tex, args.texture, common.limits(args))


def _synthesize(args, decoder, textons, size: tuple[int, int], short: int, labels=None,
                source=None):
    """(image (3, H, W), Arrangement) with a progress bar over the synthesis iterations."""
    from tqdm import tqdm

    from neuraltex.texton_synthesis import ArrangeSettings, synthesize_texture

    settings = ArrangeSettings(tileable=args.tileable, seed=args.seed or 0,
                               iterations=args.iterations, parallel=args.threads >= 2,
                               lattice=not args.no_lattice)
    bar = tqdm(total=settings.steps, disable=args.quiet, file=sys.stderr, unit="step",
               desc="arranging", dynamic_ncols=True)

    def tick(state) -> None:
        bar.set_postfix(textons=len(state.samples.cluster.unique()),
                        energy=f"{state.energy:.3f}")
        bar.update(1)
        if bar.n == bar.total:
            bar.set_description("decoding")

    try:
        image, arr = synthesize_texture(decoder, textons, short, size, settings, tick, labels,
                                        source)
    finally:
        bar.close()
    if arr.lattice is not None:  # say so: the user may want the free arrangement instead
        px = [[round(float(v) * short, 1) + 0.0 for v in a] for a in arr.lattice]  # no -0.0
        periods = " and ".join(f"({x:.1f}, {y:.1f})" for x, y in px)
        print(f"the picture repeats with periods {periods} px: " + (
            "its cells tiled (--no-lattice: arrange freely)" if arr.kept == "lattice" else
            ("the tileable canvas is not a whole number of cells" + _whole_size(arr, size, short)
             if args.tileable else "no whole cell in the input") + ", arranged freely"),
            file=sys.stderr)
    return image, arr


def _whole_size(arr, size: tuple[int, int], short: int) -> str:
    """' (--size H W is)': the nearest tileable size of whole cells of the arrangement's
    lattice (cvt.lattice.axis_periods), or '' when its periods along the axes are not whole
    pixels to 0.05 px (or there are none)."""
    import numpy as np

    from cvt.lattice import Lattice, axis_periods, whole_periods

    got = axis_periods(Lattice.given(arr.lattice))
    if got is None:
        return ""
    period = got[1][::-1] * short  # (H, W) px
    if not np.allclose(period, np.round(period), atol=0.05):
        return ""
    h, w = (int(v) for v in whole_periods(size, np.round(period)))
    return f" (--size {h} {w} is)"


def _check_svg(path: Path) -> None:
    from neuraltex.fileio import check_writable

    if path.suffix.lower() != ".svg":
        raise InputError(f"{path}: --preview-textons writes an .svg")
    check_writable(path)


def _write_svg(arr, path: Path, size: tuple[int, int], short: int) -> None:
    """The arranged textons as SVG ellipses in their colours, over the background's (or the
    ground's) colour, ``short`` pixels per unit (the raster output's size)."""
    from dataclasses import replace

    from cvt.from_textons import with_backdrop
    from cvt.svg import to_svg
    from neuraltex.fileio import write_text_atomic

    canvas = arr.textons.canvas
    text = to_svg(replace(arr.exemplar, unit_scale=(short, "")), arr.svg_placements, canvas)
    text = with_backdrop(text, arr.background_fill)
    write_text_atomic(path, text)
    count = sum(len(arr.groups[g]) for g, _, _ in arr.svg_placements)
    print(f"wrote {path} ({count} ellipses, {size[1]}x{size[0]} canvas)")


def add_commands(sub) -> None:
    p = common.model_command(
        sub, "synthesize", cmd_synthesize, "grow a texture: a bigger (or tileable) picture "
        "of it, its textons arranged by cvt", "texture",
        f"output picture ({common.IMAGE_OUT})", size=False)
    p.add_argument("--size", type=types.integer(1, 2**16), nargs=2, metavar=("H", "W"),
                   help="output size in pixels (any aspect ratio)")
    p.add_argument("--scale", type=types.number(0, MAX_SCALE, open_lo=True),
                   help="output size as a multiple of the input's")
    p.add_argument("--tileable", action="store_true",
                   help="the output repeats without a seam when tiled")
    p.add_argument("--preview-textons", type=Path, metavar="OUT.svg",
                   help="also write the arranged textons as SVG ellipses")
    p.add_argument("--no-lattice", action="store_true",
                   help="arrange freely even when the picture repeats a tile (by default its "
                   "lattice is kept: the output is tiled with the input's cells, each from a "
                   "random whole cell of the input)")
    p.add_argument("--iterations", type=types.integer(1, 50), default=3,
                   help="synthesis iterations (search + assignment) per level (default 3)")
    common.add_source_option(p, "the placed elements bring",
                             " (an image input is always its own source)")
    p.add_argument("--decode-only", action="store_true",
                   help="paint the arranged textons with the decoder only (no pixels "
                   "pasted under the placed elements)")
    p.add_argument("--threads", type=types.integer(1, 256), default=min(2, usable_cores()),
                   help="CPU threads; with 2 or more the two arrangements (the textons in "
                   "groups, and one by one) run side by side (default: 2, or 1 on a one-core "
                   "machine)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
