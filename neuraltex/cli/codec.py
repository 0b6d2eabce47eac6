"""The ``neuraltex`` subcommands that encode, decode and inspect: encode, decode, reconstruct,
overlay, textons, model-info."""

from __future__ import annotations

import argparse
from pathlib import Path

from neuraltex.cli import args as types
from neuraltex.cli import common
from neuraltex.cli.common import IMAGE_OUT
from neuraltex.errors import InputError


def cmd_encode(args: argparse.Namespace) -> int:
    """Encode an image into textons (.json or .pt), optionally with an overlay picture."""
    from neuraltex.imageio import check_output_path, save_pil
    from neuraltex.overlay import draw_overlay
    from neuraltex.textons_file import save_textons

    common.check_textons_out(args.output)
    if args.overlay:
        check_output_path(args.overlay)
    model = common.load(args.checkpoint, args.device, args.seed)
    image, enc = common.encode(model, args.image, common.limits(args), args.device,
                              args.tile)
    save_textons(enc.textons, args.output)
    n = int(enc.textons.num_effective()[0])
    print(f"wrote {args.output}: {n} effective textons of {enc.textons.num_textons}")
    if args.overlay:
        save_pil(draw_overlay(image, enc.textons, enc.masks[0], scale=2), args.overlay)
        print(f"wrote {args.overlay}")
    return 0


def cmd_decode(args: argparse.Namespace) -> int:
    """Decode a texton file into an image of any size."""
    import torch

    from neuraltex.imageio import check_output_path, save_image
    from neuraltex.textons_file import load_textons

    check_output_path(args.output)
    textons = load_textons(args.textons).to(dtype=torch.float32)
    model = common.load(args.checkpoint, args.device, args.seed)
    common.check_fits(textons, model, args.textons)
    size = common.output_size(args.size, textons.canvas, 256, common.limits(args))
    out = common.decode(model, textons, size, args.device)
    save_image(out[0], args.output)
    print(f"wrote {args.output} ({size[1]}x{size[0]})")
    return 0


def cmd_reconstruct(args: argparse.Namespace) -> int:
    """Encode an image (or read a texture file, .ntex) and decode it again (at its own size
    unless --size); a texture file decodes with its tuned decoder."""
    from neuraltex.imageio import check_output_path

    check_output_path(args.output)
    model = common.load(args.checkpoint, args.device, args.seed)
    tex = common.textons_of(model, args.image, common.limits(args), args.device,
                            args.tile)
    size = common.output_size(args.size, tex.textons.canvas, tex.short, common.limits(args))
    common.save(common.decode(tex.decoder or model, tex.textons, size, args.device)[0],
                args.output)
    return 0


def cmd_overlay(args: argparse.Namespace) -> int:
    """Picture of the textons of an image: segments, Gaussian ellipses, directions."""
    from neuraltex.fileio import check_writable, write_text_atomic
    from neuraltex.imageio import check_output_path, save_pil
    from neuraltex.overlay import draw_overlay, ellipses_svg

    check_output_path(args.output)
    if args.svg and args.svg.suffix != ".svg":
        raise InputError(f"{args.svg}: must end in .svg")
    if args.svg:
        check_writable(args.svg)
    model = common.load(args.checkpoint, args.device, args.seed)
    image, enc = common.encode(model, args.image, common.limits(args), args.device,
                              args.tile)
    save_pil(draw_overlay(image, enc.textons, enc.masks[0], scale=args.scale), args.output)
    print(f"wrote {args.output}")
    if args.svg:
        H, W = image.shape[-2:]
        write_text_atomic(args.svg, ellipses_svg(enc.textons, W, H))
        print(f"wrote {args.svg}")
    return 0


def cmd_textons(args: argparse.Namespace) -> int:
    """Validate a texton file, print a summary, optionally convert it (.json <-> .pt)."""
    from neuraltex.textons_file import load_textons, save_textons

    if args.to:
        common.check_textons_out(args.to)
    t = load_textons(args.file)
    print(f"{args.file}: {t.batch_size} set(s) x {t.num_textons} textons, "
          f"{t.feature_dim} feature channels, canvas {t.canvas[0]:g} x {t.canvas[1]:g}, "
          f"{t.dtype}".replace("torch.", ""))
    for b, n in enumerate(t.num_effective().tolist()):
        print(f"  set {b}: {n} effective textons (delta > 0.5)")
    if args.to:
        save_textons(t, args.to)
        print(f"wrote {args.to}")
    return 0


def cmd_model_info(args: argparse.Namespace) -> int:
    """Print which model is used and how it was trained (validates the weights too)."""
    import json

    from neuraltex.checkpoint import summary
    from neuraltex.model import DEFAULT_MODEL

    path = Path(args.checkpoint) if args.checkpoint else DEFAULT_MODEL
    model = common.load(args.checkpoint, args.device)
    n = sum(p.numel() for p in model.parameters())
    print(f"model: {path}{' (shipped default)' if not args.checkpoint else ''}")
    print(f"{n / 1e6:.2f} M parameters; {summary(model.config.to_dict(), model.info)}")
    print(f"fit prior: {_prior_line(model, path)}")
    if args.json:
        print(json.dumps({"config": model.config.to_dict(), "info": model.info}, indent=1))
    return 0


def _prior_line(model, weights: Path) -> str:
    """Where ``neuraltex fit`` starts tuning G (neuraltex.fit_prior), in one line."""
    from neuraltex.fit_prior import prior_path

    if getattr(model, "fit_prior", None) is None:
        return "none (fit starts from this model's G)"
    info = model.fit_prior[1].get("info", {})
    return (f"{prior_path(weights).name} (Reptile, {info.get('iterations_done', '?')} "
            f"iterations of {info.get('inner_steps', '?')} tuning steps on "
            f"{info.get('tasks', '?')} procedural textures)")


def add_commands(sub) -> None:
    """Register textons, encode, decode, reconstruct, overlay and model-info."""
    p = sub.add_parser("textons", help="check, summarize and convert a texton file",
                       description=cmd_textons.__doc__)
    p.add_argument("file", type=Path, help="texton file (.json or .pt)")
    p.add_argument("--to", type=Path, help="also write the textons to this .json or .pt file")
    p.set_defaults(func=cmd_textons)

    p = common.model_command(sub, "encode", cmd_encode, "image -> textons file", "image",
                             "textons .json or .pt", size=False)
    p.add_argument("--overlay", type=Path, help="also write an overlay picture")
    common.model_command(sub, "decode", cmd_decode, "textons file -> image", "textons",
                         IMAGE_OUT)
    common.model_command(sub, "reconstruct", cmd_reconstruct, "image -> textons -> image",
                         "image", IMAGE_OUT)
    p = common.model_command(sub, "overlay", cmd_overlay, "picture of an image's textons",
                             "image", IMAGE_OUT, size=False)
    p.add_argument("--svg", type=Path, help="also write the Gaussians as SVG ellipses")
    p.add_argument("--scale", type=types.integer(1, 4), default=2,
                   help="picture magnification, 1 to 4 (default 2)")

    p = sub.add_parser("model-info", help="which model is used and how it was trained",
                       description=cmd_model_info.__doc__)
    p.add_argument("--checkpoint", help="model .safetensors (default: the shipped model)")
    p.add_argument("--device", default="cpu", type=types.device,
                   help="torch device: cpu (default), cuda, cuda:N or mps")
    p.add_argument("--json", action="store_true", help="also print the full header as JSON")
    p.set_defaults(func=cmd_model_info)
