"""The ``neuraltex`` command line.

Subcommands are small functions ``cmd_<name>(args) -> int`` registered in :func:`build_parser`;
user errors raise :class:`neuraltex.errors.InputError` and become one line + exit code 2.
"""

from __future__ import annotations

import argparse

from neuraltex import __version__
from neuraltex.errors import InputError, cli_entry


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


def build_parser() -> argparse.ArgumentParser:
    from pathlib import Path

    parser = argparse.ArgumentParser(
        prog="neuraltex",
        description="Gaussian-texton textures: encode, edit and decode textures as textons.",
    )
    parser.add_argument("--version", action="version", version=f"neuraltex {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("textons", help="check, summarize and convert a texton file",
                       description=cmd_textons.__doc__)
    p.add_argument("file", type=Path, help="texton file (.json or .pt)")
    p.add_argument("--to", type=Path, help="also write the textons to this .json or .pt file")
    p.set_defaults(func=cmd_textons)
    return parser


@cli_entry("neuraltex")
def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
