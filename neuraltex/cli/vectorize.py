"""The ``neuraltex vectorize`` subcommand: an image as an SVG of its textons (or segments)."""

from __future__ import annotations

import argparse

from neuraltex.cli import args as types
from neuraltex.cli import common
from neuraltex.errors import InputError
from neuraltex.limits import MAX_PIXELS_VECTORIZE


def cmd_vectorize(args: argparse.Namespace) -> int:
    """Vectorize an image: one SVG element per texton (or segment), filled with the image's
    colours, drawn in compositing order over a background layer. A texture file (.ntex) gives
    its fitted segments, coloured by its tuned reconstruction."""
    from neuraltex.fileio import check_writable, write_text_atomic
    from neuraltex.imageio import load_image
    from neuraltex.segments import segment_image
    from neuraltex.vectorize import VectorizeParams, ellipses, to_svg, vectorize

    if args.output.suffix != ".svg":
        raise InputError(f"{args.output}: must end in .svg")
    check_writable(args.output)
    texture_file = args.image.suffix.lower() == common.TEXTURE_FILE
    if args.mode == "ellipse" and args.segmenter != "model" and not texture_file:
        raise InputError("--mode ellipse needs textons (--segmenter model or a texture file)")
    model = None
    if args.segmenter == "model" or texture_file:
        model = common.load(args.checkpoint, args.device, args.seed)
    if texture_file:
        image, seg, textons = _texture_segments(model, args)
    else:
        image = load_image(args.image, limits=common.limits(args)).to(args.device)
        seg, textons = segment_image(image, args.segmenter, model, args.source,
                                     background=not args.keep_backdrop, tile=args.tile)
    params = VectorizeParams(gradient=not args.no_gradient, background=args.background,
                             kinds=args.kinds)
    arr = image.permute(1, 2, 0).cpu().numpy()
    if args.mode == "ellipse":
        t = textons.index(seg.index[None]) if seg.count else textons
        vec = ellipses(arr, seg, t.mu[0].cpu().numpy(), t.cov[0].cpu().numpy(), params,
                       args.level)
    else:
        vec = vectorize(arr, seg, params)
    text = to_svg(vec, seg, params.seam)
    write_text_atomic(args.output, text)
    print(f"wrote {args.output}: {len(vec.elements)} elements of {seg.count} segments, "
          f"{len(text.encode()) / 1024:.1f} KiB")
    return 0


def _texture_segments(model, args: argparse.Namespace):
    """(image, segments, textons) of a texture file: its fitted segments, coloured by its
    tuned reconstruction."""
    from neuraltex.segments import drop_background, from_texture
    from neuraltex.texture_file import load_texture

    tex = load_texture(args.image, model)
    image, seg = from_texture(tex, model)
    return image, (seg if args.keep_backdrop else drop_background(seg)), tex.textons.to(
        device=args.device)


def add_commands(sub) -> None:
    """Register vectorize."""
    p = common.model_command(sub, "vectorize", cmd_vectorize, "image -> SVG of its textons",
                             "image", "output .svg", size=False,
                             max_pixels=MAX_PIXELS_VECTORIZE)
    p.add_argument("--mode", choices=("regions", "ellipse"), default="regions",
                   help="regions (default): traced segment outlines; ellipse: the Gaussians")
    p.add_argument("--segmenter", default="model",
                   choices=("model", "felzenszwalb", "slic", "kmeans", "grid"),
                   help="where segments come from (default: the texton model)")
    p.add_argument("--source", choices=("masks", "splat"), default="masks",
                   help="texton segments from the segmentation masks (default) or the "
                   "composited splat weights")
    p.add_argument("--background", choices=("flat", "grid"), default="flat",
                   help="background layer: one colour or a coarse grid of rectangles")
    p.add_argument("--no-gradient", action="store_true", help="flat fills only")
    p.add_argument("--keep-backdrop", action="store_true",
                   help="keep a segment that spans the whole image as an element (default: "
                   "it becomes the background layer)")
    p.add_argument("--kinds", type=types.integer(1, 256), default=4,
                   help="kind clusters, 1 to 256 (default 4)")
    p.add_argument("--level", type=types.number(0, 10, open_lo=True), default=1.0,
                   help="Mahalanobis level of the ellipses, in (0, 10] (--mode ellipse, default 1)")
