"""Errors a user can cause, and the one-line, exit-code-2 way the CLIs report them."""

from __future__ import annotations

import argparse
import functools
import os
import sys
from collections.abc import Callable

EXIT_USAGE = 2


class InputError(ValueError):
    """Bad user input (missing/corrupt file, wrong format, hostile content).

    The CLIs print ``<prog>: error: <message>`` on one line and exit with code 2.
    """


def cli_entry(prog: str) -> Callable[[Callable[..., int | None]], Callable[..., int]]:
    """Decorate a CLI ``main`` so user errors become one line on stderr and exit code 2."""

    def wrap(main: Callable[..., int | None]) -> Callable[..., int]:
        @functools.wraps(main)
        def run(*args, **kwargs) -> int:
            try:
                return main(*args, **kwargs) or 0
            except InputError as exc:
                print(f"{prog}: error: {one_line(exc)}", file=sys.stderr)
                return EXIT_USAGE
            except KeyboardInterrupt:
                print(f"{prog}: interrupted", file=sys.stderr)
                return 130
            except BrokenPipeError:  # e.g. `cvt inspect X.svg | head`: stop quietly
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
                return 1

        return run

    return wrap


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are :class:`InputError`: one line, exit code 2 (through
    :func:`cli_entry`) instead of the usage block; ``--help`` shows the usage."""

    def error(self, message: str):
        raise InputError(f"{message} (see {self.prog} --help)")


def dispatch(parser, argv: list[str] | None = None) -> int:
    """Parse ``argv`` and run the chosen subcommand's ``func``; no subcommand prints help."""
    args = parser.parse_args(argv)
    if getattr(args, "command", None) is None:
        parser.print_help()
        return 0
    return args.func(args)


def one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__
