"""Argument types of the ``neuraltex`` subcommands: every number is checked for range and
finiteness, and ``--device`` for availability, when the command line is parsed, so a bad
value is one argparse error line (exit code 2) before any file is read."""

from __future__ import annotations

import argparse
import math

SEED_MAX = 2**32 - 1  # what every RNG in the pipeline (torch, NumPy) accepts


def integer(lo: int, hi: int):
    """An argparse type: an int in [lo, hi]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{value} is outside [{lo}, {hi}]")
        return value

    parse.__name__ = "integer"
    return parse


def number(lo: float, hi: float, open_lo: bool = False):
    """An argparse type: a finite float in [lo, hi] (or (lo, hi] with ``open_lo``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        low_ok = value > lo if open_lo else value >= lo
        if not (math.isfinite(value) and low_ok and value <= hi):
            raise argparse.ArgumentTypeError(
                f"{text} is outside {'(' if open_lo else '['}{lo:g}, {hi:g}]")
        return value

    parse.__name__ = "number"
    return parse


seed = integer(0, SEED_MAX)


def device(text: str) -> str:
    """An argparse type: a torch device that exists on this machine (cpu, cuda, cuda:1, mps)."""
    problem = device_problem(text)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return text


def device_problem(text: str) -> str | None:
    """Why ``text`` is not a usable torch device here, or None when it is."""
    import torch

    try:
        dev = torch.device(text)
    except (RuntimeError, ValueError, TypeError):
        return f"unknown device {text!r} (cpu, cuda, cuda:N, mps)"
    if dev.type == "cpu":
        return None
    if dev.type == "cuda" and torch.cuda.is_available():
        if dev.index is None or dev.index < torch.cuda.device_count():
            return None
        return f"{text}: this machine has {torch.cuda.device_count()} CUDA device(s)"
    if dev.type == "mps" and torch.backends.mps.is_available():
        return None
    return f"{text}: no such device on this machine (use cpu)"


def output_file(*suffixes: str):
    """An argparse type: a path a file can be written to (neuraltex.fileio.check_writable),
    ending in one of ``suffixes`` (any case); checked before any work is done."""

    def parse(text: str) -> str:
        from neuraltex.errors import InputError
        from neuraltex.fileio import check_writable

        if not text.lower().endswith(suffixes):
            raise argparse.ArgumentTypeError(f"{text!r}: the name must end in "
                                             f"{' or '.join(suffixes)}")
        try:
            check_writable(text)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    parse.__name__ = "output file"
    return parse
