"""Keep freed memory in the process heap (glibc), so that large tensors are not page-faulted
in afresh each time they are allocated.

glibc serves an allocation above its mmap threshold (128 KiB at first, rising to at most
32 MiB as large blocks are freed) with a fresh ``mmap`` and hands it back to the OS on
``free``, and trims the heap top above 128 KiB of free space. A training step allocates and
frees hundreds of 1-15 MB tensors (the segmenter's (B, n, P) masks, G's feature maps), so the
kernel zero-fills and maps every page of each again and again: on a 2-core machine, e.g.,
``log(S.clamp_min(eps))`` of an (8, 100, 1024) tensor took 1.9 ms against 0.5 ms from reused
memory. Fixed thresholds (``mallopt``, the same as the ``MALLOC_*_`` environment variables
set before the process starts) keep such blocks in the heap for reuse: the segmenter's
training step at 128 px 1.05-1.1x (page-fault system time 16-21 ms a full step -> 0),
``neuraltex fit --steps 100`` 10.0-11.5 -> 9.6-10.3 s (three runs each, interleaved) with the
same peak memory (1.0 GB); freed memory up to the trim threshold stays with the process until
it exits.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3
MMAP_THRESHOLD = 64 << 20  # blocks below 64 MiB come from the heap and are reused
TRIM_THRESHOLD = 128 << 20  # up to 128 MiB of free heap top is kept, not given back
TOP_PAD = 16 << 20  # the heap grows in 16 MiB steps
# (256 / 512 / 64 MiB made no step faster and `neuraltex fit` peak at 1.4-1.5 GB, not 1.0)


def keep_freed_memory() -> bool:
    """Set glibc's thresholds for this process (from now on); False where the C library is
    not glibc (macOS, Windows, musl) and nothing was changed."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return all(mallopt(param, value) == 1 for param, value in (
        (_M_MMAP_THRESHOLD, MMAP_THRESHOLD), (_M_TRIM_THRESHOLD, TRIM_THRESHOLD),
        (_M_TOP_PAD, TOP_PAD)))
