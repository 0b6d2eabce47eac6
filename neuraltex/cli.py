"""The ``neuraltex`` command line."""

from __future__ import annotations

import argparse

from neuraltex import __version__
from neuraltex.errors import cli_entry


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="neuraltex",
        description="Gaussian-texton textures: encode, edit and decode textures as textons.",
    )
    parser.add_argument("--version", action="version", version=f"neuraltex {__version__}")
    parser.add_subparsers(dest="command", metavar="COMMAND")
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
