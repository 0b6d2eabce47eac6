"""``neuraltex fit``: tune the decoder to one texture and write a texture file (.ntex) that
every editing command reads in place of the image."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from neuraltex.cli import args as types
from neuraltex.cli import common
from neuraltex.errors import InputError
from neuraltex.query_grid import MAX_QUERIES
from neuraltex.texture_file import MAX_SPRITE

MAX_FIT_SIDE = 1024


def cmd_fit(args: argparse.Namespace) -> int:
    """Tune the model to one texture (segments -> textons, then the decoder G and the textons'
    appearance, for --seconds or --steps, then a detail sprite per texton) and write a texture
    file (.ntex): sharp
    reconstructions and edits of that texture with every other command."""
    import torch

    from neuraltex.fileio import file_sha256
    from neuraltex.fit import SEGMENTERS, FitSettings, fit_texture
    from neuraltex.imageio import check_output_path, load_image
    from neuraltex.nn_utils import shrink_short_side
    from neuraltex.texture_file import SUFFIX, save_texture

    _check(args)
    torch.set_num_threads(args.threads)
    if args.output.suffix.lower() != SUFFIX:
        raise InputError(f"{args.output}: a texture file must end in {SUFFIX}")
    if args.preview:
        check_output_path(args.preview)
    if args.segmenter not in SEGMENTERS:
        raise InputError(f"--segmenter must be one of {', '.join(SEGMENTERS)}")
    model = common.load(args.checkpoint, args.device, args.seed)
    image = load_image(args.image, max_side=args.max_side)
    h, w = image.shape[-2:]
    image = shrink_short_side(image[None], args.size)[0].clamp(0, 1).to(args.device)
    seconds = DEFAULT_SECONDS if args.seconds is None and args.steps is None else args.seconds
    settings = FitSettings(segmenter=args.segmenter, seconds=seconds, steps=args.steps,
                           max_textons=args.max_textons, detail=args.detail, seed=args.seed or 0,
                           queries=args.queries)
    begin = time.perf_counter()
    fit = fit_texture(model, image, settings)
    total = time.perf_counter() - begin
    source = {"file": args.image.name, "width": w, "height": h,
              "sha256": file_sha256(args.image)}
    header = {"source": source, "size": list(image.shape[-2:]), "segmenter": fit.segmenter,
              "fit": {"steps": fit.steps, "seconds": round(fit.seconds, 2),
                      "psnr": round(fit.psnr, 3), "base_psnr": round(fit.base_psnr, 3),
                      "plain_psnr": round(fit.plain_psnr, 3), "detail": fit.detail}}
    size = save_texture(args.output, model, fit.textons, fit.labels, fit.generator, header,
                        fit.elements)
    print(f"{fit.segmenter} segments -> {fit.textons.num_textons} textons; tuned "
          f"{fit.steps} steps in {fit.seconds:.1f} s: PSNR {fit.base_psnr:.2f} -> "
          f"{fit.plain_psnr:.2f} dB" + (f"; {fit.detail} px detail sprites "
                                        f"({fit.detail_seconds:.1f} s) -> {fit.psnr:.2f} dB"
                                        if fit.detail else "") + f"; {total:.1f} s in all")
    print(f"wrote {args.output} ({size / 1024:.0f} KB)")
    if args.preview:
        from neuraltex.tuned_decoder import tuned_model

        with torch.no_grad():
            out = tuned_model(model, fit.generator).decode(fit.textons, tuple(image.shape[-2:]))
        common.save(torch.cat([image, out[0]], dim=-1), args.preview)
    return 0


DEFAULT_SECONDS = 55.0


def _detail_side(text: str) -> int | None:
    """--detail: 'auto' (None) or a whole number (checked by _check)."""
    if text == "auto":
        return None
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not 'auto' or an integer: {text!r}") from None


def _check(args: argparse.Namespace) -> None:
    if args.seconds is not None and not 0 < args.seconds < 1e6:
        raise InputError(f"--seconds must be a positive number, got {args.seconds}")
    if args.steps is not None and not 1 <= args.steps <= 10**6:
        raise InputError(f"--steps must lie in 1..1000000, got {args.steps}")
    if not 16 <= args.size <= MAX_FIT_SIDE:
        raise InputError(f"--size must lie in 16..{MAX_FIT_SIDE}, got {args.size}")
    if not 1 <= args.threads <= 256:
        raise InputError(f"--threads must lie in 1..256, got {args.threads}")
    if not 2 <= args.max_textons <= 4096:
        raise InputError(f"--max-textons must lie in 2..4096, got {args.max_textons}")
    if args.queries is not None:
        if args.segmenter != "model":
            raise InputError("--queries applies to --segmenter model only")
        if not 1 <= args.queries <= MAX_QUERIES:
            raise InputError(f"--queries must lie in 1..{MAX_QUERIES}, got {args.queries}")
    if args.detail not in (None, 0) and not 2 <= args.detail <= MAX_SPRITE:
        raise InputError(f"--detail must be auto, 0 or lie in 2..{MAX_SPRITE}, got {args.detail}")


def add_commands(sub) -> None:
    """Register fit."""
    from neuraltex.fit import SEGMENTERS
    from neuraltex.segmenters import MAX_SEGMENTS
    from neuraltex.texton_detail import MAX_SIDE, MIN_SIDE

    p = sub.add_parser("fit", help="tune the model to one texture -> texture file (.ntex)",
                       description=cmd_fit.__doc__)
    p.add_argument("image", type=Path, help="the texture image (any common format)")
    p.add_argument("-o", "--output", type=Path, required=True,
                   help="texture file to write (.ntex)")
    p.add_argument("--seconds", type=float,
                   help=f"time budget of the whole fit in seconds: segments, tuning, elements "
                   f"and sprites; the tuning gets what the rest leaves (default "
                   f"{DEFAULT_SECONDS:g} unless --steps is given; loading the model comes on "
                   "top)")
    p.add_argument("--steps", type=int,
                   help="tuning step budget; alone (without --seconds) the run is reproducible "
                   "for a --seed")
    p.add_argument("--segmenter", default="auto", choices=SEGMENTERS,
                   help="where the texton masks come from: the learned E_s ('model', refined to "
                   "the image's edges), a classical segmenter, or 'auto' (default: picks "
                   "Felzenszwalb or SLIC by how well their textons' colours splat back)")
    p.add_argument("--queries", type=int,
                   help="with --segmenter model: E_s's queries (100 in the shipped model, at "
                   "most that many textons) resampled to this many, without training, for "
                   "dense textures: more and smaller textons, a sharper fit, about 2x the "
                   "textons per element at 196 (docs/real_textures.md: +0.7 to +4.8 dB on "
                   "five textures)")
    p.add_argument("--size", type=int, default=256,
                   help="fit at this short side; larger images are downscaled (default 256)")
    p.add_argument("--max-textons", type=int, default=MAX_SEGMENTS,
                   help=f"at most this many textons (default {MAX_SEGMENTS})")
    p.add_argument("--detail", type=_detail_side, default=None,
                   help="side of each texton's detail sprite, texels: the fine detail G misses, "
                   "moving with the texton in every edit; 'auto' (default): about 2 texels per "
                   f"pixel over all textons, {MIN_SIDE}..{MAX_SIDE}; 0: no sprites")
    p.add_argument("--preview", type=Path,
                   help="also write input | tuned reconstruction side by side (.png/.jpg/.webp)")
    p.add_argument("--checkpoint", help="base model .safetensors (default: the shipped model)")
    p.add_argument("--device", default="cpu", type=types.device,
                   help="torch device (default: cpu)")
    p.add_argument("--threads", type=int, default=1,
                   help="torch CPU threads (default 1: the tiny decoder's convolutions gain "
                   "nothing from more, and a busy machine makes them much slower)")
    p.add_argument("--seed", type=types.seed, help=f"random seed in [0, {types.SEED_MAX}] "
                   "(default 0)")
    p.add_argument("--max-side", type=int, default=2048,
                   help="larger inputs are downscaled to this side on reading (default 2048)")
    p.set_defaults(func=cmd_fit)
