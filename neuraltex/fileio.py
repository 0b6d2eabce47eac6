"""Atomic file output: write to a temporary file in the target folder, then rename.

A crash or a bad input half-way never leaves a truncated output behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it onto ``path``.

    The temporary file keeps the suffix of ``path`` so writers that pick a format
    by extension (PIL, torch, svg writers) behave the same.
    """
    path = check_writable(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem[:64]}.tmp-", suffix=path.suffix,
                                   dir=path.parent)
    except OSError as exc:
        raise _unwritable(path, exc) from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes the file private (0600); outputs get the usual umask permissions.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp_path, 0o666 & ~umask)
        os.replace(tmp_path, path)
    except OSError as exc:
        raise _unwritable(path, exc) from None
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def check_writable(path: str | os.PathLike) -> Path:
    """``path`` as a Path when a file could be written there: a non-empty name of at most
    255 bytes, not a folder, under a folder that exists (or can be made) and is writable.
    Raises :class:`neuraltex.errors.InputError` otherwise, before any work is done."""
    from neuraltex.errors import InputError

    path = Path(path)
    if not path.name or str(path) in (".", "..") or "\0" in str(path):
        raise InputError(f"{str(path)!r}: not a file name")
    if len(os.fsencode(path.name)) > 255:
        raise InputError(f"{path.name[:40]}...: file name longer than 255 bytes")
    try:
        if path.is_dir():
            raise InputError(f"{path}: is a folder")
        folder = path.parent
        while not folder.exists() and folder != folder.parent:
            folder = folder.parent
        writable = os.access(folder, os.W_OK | os.X_OK)
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the name
        raise _unwritable(path, exc) from None
    if not folder.is_dir():
        raise InputError(f"{path}: {folder} is not a folder")
    if not writable:
        raise InputError(f"{path}: folder {folder} is not writable")
    return path


def _unwritable(path: Path, exc: Exception) -> Exception:
    from neuraltex.errors import InputError, one_line

    return InputError(f"{path}: cannot write ({one_line(exc)})")


def file_sha256(path: str | os.PathLike) -> str:
    """Hex sha256 of a file's bytes, read in chunks (bounded memory)."""
    import hashlib

    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


def load_weights_only(path: str | os.PathLike, error: type[Exception], what: str):
    """``torch.load`` that never runs pickled code (``weights_only=True``); any failure is
    raised as ``error`` with a one-line message naming ``what`` the file should have been."""
    import pickle

    import torch

    from neuraltex.errors import one_line

    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, OSError, ValueError) as exc:
        raise error(f"{path}: not a loadable {what} ({one_line(exc)[:200]})") from None
