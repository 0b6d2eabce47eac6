"""The ``neuraltex`` command line.

Subcommands are small functions ``cmd_<name>(args) -> int`` registered in :func:`build_parser`;
user errors raise :class:`neuraltex.errors.InputError` and become one line + exit code 2.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from neuraltex import __version__
from neuraltex.errors import InputError, cli_entry, dispatch

DEFAULT_MODEL = Path(__file__).resolve().parent / "weights" / "default.safetensors"


def _model(args: argparse.Namespace):
    import torch

    from neuraltex.model import load_model

    path = Path(args.checkpoint) if args.checkpoint else DEFAULT_MODEL
    if not args.checkpoint and not path.exists():
        raise InputError("no default model is shipped yet; pass --checkpoint MODEL.safetensors "
                         "(python -m train writes one)")
    if args.seed is not None:
        torch.manual_seed(args.seed)
    return load_model(path, device=args.device)


def _size(args: argparse.Namespace, canvas: tuple[float, float], default_short: int):
    """(H, W) from --size N (short side) or --size H W, else the canvas at default_short."""
    if args.size:
        if len(args.size) == 2:
            return int(args.size[0]), int(args.size[1])
        short = int(args.size[0])
    else:
        short = default_short
    w, h = canvas
    s = short / min(w, h)
    return max(1, round(h * s)), max(1, round(w * s))


def _encode(args: argparse.Namespace, model, path: Path | None = None):
    """(image (3, H, W), model.encode(image)) for ``path`` (default: ``args.image``)."""
    import torch

    from neuraltex.imageio import load_image

    image = load_image(path or args.image, max_side=args.max_side).to(args.device)
    with torch.no_grad():
        return image, model.encode(image[None])


def _check_fits(textons, model, source: Path) -> None:
    if textons.feature_dim + 2 != model.generator.feature_channels:
        raise InputError(f"{source}: {textons.feature_dim} feature channels, but the "
                         f"model expects {model.generator.feature_channels - 2}")


def cmd_encode(args: argparse.Namespace) -> int:
    """Encode an image into textons (.json or .pt), optionally with an overlay picture."""
    from neuraltex.imageio import check_output_path, save_pil
    from neuraltex.overlay import draw_overlay
    from neuraltex.textons_file import save_textons

    if args.output.suffix not in (".json", ".pt"):
        raise InputError(f"{args.output}: textons are written as .json or .pt")
    if args.overlay:
        check_output_path(args.overlay)
    image, enc = _encode(args, _model(args))
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
    textons = load_textons(args.textons)
    model = _model(args)
    _check_fits(textons, model, args.textons)
    size = _size(args, textons.canvas, 256)
    with torch.no_grad():
        out = model.decode(textons.to(device=args.device), size)
    save_image(out[0], args.output)
    print(f"wrote {args.output} ({size[1]}x{size[0]})")
    return 0


def cmd_reconstruct(args: argparse.Namespace) -> int:
    """Encode an image and decode it again (at its own size unless --size)."""
    import torch

    from neuraltex.imageio import check_output_path, save_image

    check_output_path(args.output)
    image, enc = _encode(args, model := _model(args))
    size = _size(args, enc.textons.canvas, min(image.shape[-2:]))
    with torch.no_grad():
        out = model.decode(enc.textons, size)
    save_image(out[0], args.output)
    print(f"wrote {args.output} ({size[1]}x{size[0]})")
    return 0


def cmd_overlay(args: argparse.Namespace) -> int:
    """Picture of the textons of an image: segments, Gaussian ellipses, directions."""
    from neuraltex.fileio import write_text_atomic
    from neuraltex.imageio import check_output_path, save_pil
    from neuraltex.overlay import draw_overlay, ellipses_svg

    check_output_path(args.output)
    if args.svg and args.svg.suffix != ".svg":
        raise InputError(f"{args.svg}: must end in .svg")
    image, enc = _encode(args, _model(args))
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

    t = load_textons(args.file)
    print(f"{args.file}: {t.batch_size} set(s) x {t.num_textons} textons, "
          f"{t.feature_dim} feature channels, canvas {t.canvas[0]:g} x {t.canvas[1]:g}, "
          f"{t.dtype}".replace("torch.", ""))
    for b, n in enumerate(t.num_effective().tolist()):
        print(f"  set {b}: {n} effective textons (delta > 0.5)")
    if args.to:
        if args.to.suffix not in (".json", ".pt"):
            raise InputError(f"{args.to}: output must end in .json or .pt")
        save_textons(t, args.to)
        print(f"wrote {args.to}")
    return 0


def cmd_model_info(args: argparse.Namespace) -> int:
    """Print which model is used and how it was trained (validates the weights too)."""
    import json

    from neuraltex.checkpoint import summary

    path = Path(args.checkpoint) if args.checkpoint else DEFAULT_MODEL
    model = _model(args)
    n = sum(p.numel() for p in model.parameters())
    print(f"model: {path}{' (shipped default)' if not args.checkpoint else ''}")
    print(f"{n / 1e6:.2f} M parameters; {summary(model.config, model.info)}")
    if args.json:
        print(json.dumps({"config": model.config, "info": model.info}, indent=1))
    return 0


class _Version(argparse.Action):
    """``--version``: the package version and the shipped default model."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        from neuraltex.checkpoint import CheckpointError, export_header, summary

        print(f"neuraltex {__version__}")
        if not DEFAULT_MODEL.exists():
            print("default model: none shipped (pass --checkpoint)")
        else:
            try:
                print(f"default model: {summary(*export_header(DEFAULT_MODEL))}")
            except CheckpointError as exc:
                print(f"default model: unreadable ({exc})")
        parser.exit()


def _common(p: argparse.ArgumentParser, size: bool = True) -> None:
    p.add_argument("--checkpoint", help="model .safetensors (default: the shipped model)")
    p.add_argument("--device", default="cpu", help="torch device (default: cpu)")
    p.add_argument("--seed", type=int, help="random seed")
    p.add_argument("--max-side", type=int, default=2048,
                   help="larger inputs are downscaled to this side (default 2048)")
    if size:
        p.add_argument("--size", type=int, nargs="+", metavar="N",
                       help="output size: N (short side) or H W")


IMAGE_OUT = ".png/.jpg/.webp"


def _model_command(sub, name: str, func, help: str, source: str, output_help: str,
                   size: bool = True) -> argparse.ArgumentParser:
    """A subcommand that reads ``source``, runs the model and writes ``-o OUTPUT``."""
    p = sub.add_parser(name, help=help, description=func.__doc__)
    p.add_argument(source, type=Path)
    p.add_argument("-o", "--output", type=Path, required=True, help=output_help)
    _common(p, size=size)
    p.set_defaults(func=func)
    return p


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="neuraltex",
        description="Gaussian-texton textures: encode, edit and decode textures as textons.",
    )
    parser.add_argument("--version", action=_Version,
                        help="print the version and the default model, then exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("textons", help="check, summarize and convert a texton file",
                       description=cmd_textons.__doc__)
    p.add_argument("file", type=Path, help="texton file (.json or .pt)")
    p.add_argument("--to", type=Path, help="also write the textons to this .json or .pt file")
    p.set_defaults(func=cmd_textons)

    p = _model_command(sub, "encode", cmd_encode, "image -> textons file", "image",
                       "textons .json or .pt", size=False)
    p.add_argument("--overlay", type=Path, help="also write an overlay picture")
    _model_command(sub, "decode", cmd_decode, "textons file -> image", "textons", IMAGE_OUT)
    _model_command(sub, "reconstruct", cmd_reconstruct, "image -> textons -> image", "image",
                   IMAGE_OUT)
    from neuraltex.cli_vectorize import add_vectorize_command

    add_vectorize_command(sub)
    p = _model_command(sub, "overlay", cmd_overlay, "picture of an image's textons", "image",
                       IMAGE_OUT, size=False)
    p.add_argument("--svg", type=Path, help="also write the Gaussians as SVG ellipses")
    p.add_argument("--scale", type=int, default=2, help="picture magnification (default 2)")

    p = sub.add_parser("model-info", help="which model is used and how it was trained",
                       description=cmd_model_info.__doc__)
    p.add_argument("--checkpoint", help="model .safetensors (default: the shipped model)")
    p.add_argument("--device", default="cpu", help="torch device (default: cpu)")
    p.add_argument("--json", action="store_true", help="also print the full header as JSON")
    p.set_defaults(func=cmd_model_info, seed=None)

    from neuraltex.cli_edit import add_edit_commands

    add_edit_commands(sub)
    return parser


@cli_entry("neuraltex")
def main(argv: list[str] | None = None) -> int:
    return dispatch(build_parser(), argv)


if __name__ == "__main__":
    raise SystemExit(main())
