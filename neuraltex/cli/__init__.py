"""The ``neuraltex`` command line: ``main`` and ``build_parser``.

Subcommands are small functions ``cmd_<name>(args) -> int`` in :mod:`.codec` (encode, decode,
inspect), :mod:`.vectorize` and :mod:`.edit`, each registered by that module's
``add_commands``; what they share (loading the model, reading a texture) is in :mod:`.common`.
User errors raise :class:`neuraltex.errors.InputError` and become one line + exit code 2.
"""

from __future__ import annotations

import argparse

from neuraltex import __version__
from neuraltex.errors import OneLineParser, cli_entry, dispatch


class _Version(argparse.Action):
    """``--version``: the package version and the shipped default model."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        from neuraltex.checkpoint import CheckpointError, export_header, summary
        from neuraltex.model import DEFAULT_MODEL

        print(f"neuraltex {__version__}")
        if not DEFAULT_MODEL.exists():
            print("default model: none shipped (pass --checkpoint)")
        else:
            try:
                print(f"default model: {summary(*export_header(DEFAULT_MODEL))}")
            except CheckpointError as exc:
                print(f"default model: unreadable ({exc})")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    from neuraltex.cli import codec, edit, fit, synthesize, vectorize

    parser = OneLineParser(
        prog="neuraltex",
        description="Gaussian-texton textures: encode, edit and decode textures as textons.",
    )
    parser.add_argument("--version", action=_Version,
                        help="print the version and the default model, then exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    codec.add_commands(sub)
    fit.add_commands(sub)
    vectorize.add_commands(sub)
    edit.add_commands(sub)
    synthesize.add_commands(sub)
    return parser


@cli_entry("neuraltex")
def main(argv: list[str] | None = None) -> int:
    return dispatch(build_parser(), argv)
