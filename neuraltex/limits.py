"""Resource bounds, decided up front: how large a picture (in or out) and how many textons,
sets, frames or edits any command accepts, so hostile input fails fast with one line instead
of taking gigabytes.

The budgets are set so that every ``neuraltex`` command stays under ~2 GB with the shipped
tiny model (README, "Limits"); each has a command-line option to raise it:

- pictures read: a side above ``max_side`` or more than ``max_pixels`` pixels is downscaled
  (with a note); an aspect ratio above ``max_aspect`` is refused (``--max-aspect``);
- pictures written: more than ``max_pixels`` pixels or an aspect ratio above ``max_aspect`` is
  refused (``--size``, canvases of texton files);
- counts (variations, frames, texton sets, textons per set, edits) have fixed caps below.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from neuraltex.errors import InputError

MAX_SIDE = 2048  # --max-side
MAX_PIXELS = 2**21  # --max-pixels: 2.1 MP (1448 x 1448); decoding 1 MP takes ~1.1 GB
MAX_PIXELS_VECTORIZE = 2**20  # vectorize keeps per-segment rasters: ~1.8 GB at 1 MP
MAX_ASPECT = 8.0  # --max-aspect
MAX_COUNT = 1000  # reshuffle --count, animate/interpolate --frames
MAX_PATCHES = 4096  # stylize: content patches encoded (1024 x 768 at scale 0.5: 1,376)
MAX_SETS = 64  # texton sets in one file
MAX_TEXTONS = 4096  # textons per set (files, edits, model queries)
MAX_FEATURES = 1024  # feature channels per texton
MAX_EDITS = 1000  # edits in one edit list
MAX_MODEL_SIDE = 4096  # image_size / estimation_size of a model header


@dataclass(frozen=True)
class Limits:
    """The picture budget of one command (from ``--max-side/--max-pixels/--max-aspect``)."""

    max_side: int = MAX_SIDE
    max_pixels: int = MAX_PIXELS
    max_aspect: float = MAX_ASPECT

    def __post_init__(self) -> None:
        if self.max_side < 1 or self.max_pixels < 1 or not self.max_aspect >= 1:
            raise InputError("--max-side and --max-pixels must be >= 1, --max-aspect >= 1")

    def input_size(self, w: int, h: int, what: str) -> tuple[int, int]:
        """(w, h) a picture of ``w`` x ``h`` is read at: downscaled into the budget; an extreme
        aspect ratio is refused (it would be downscaled to nothing)."""
        self._check_aspect(w, h, what)
        s = min(1.0, self.max_side / max(w, h), math.sqrt(self.max_pixels / (w * h)))
        if s >= 1.0:
            return w, h
        return max(1, math.floor(w * s)), max(1, math.floor(h * s))

    def check_output(self, h: float, w: float, what: str = "output") -> tuple[int, int]:
        """(h, w) as ints, or InputError when a picture of that size is out of budget."""
        if not (math.isfinite(h) and math.isfinite(w)) or min(h, w) < 1:
            raise InputError(f"{what} size {h:g}x{w:g} is not a positive picture size")
        if h * w > self.max_pixels:
            raise InputError(f"{what} of {w:.0f}x{h:.0f} px is over the budget of "
                             f"{self.max_pixels} px (raise it with --max-pixels)")
        self._check_aspect(w, h, what)
        return int(h), int(w)

    def _check_aspect(self, w: float, h: float, what: str) -> None:
        if max(w, h) > self.max_aspect * min(w, h):
            raise InputError(f"{what} is {w:.0f}x{h:.0f}: aspect ratio above {self.max_aspect:g} "
                             "(raise it with --max-aspect)")


def check_count(value: int, cap: int, what: str) -> None:
    """InputError when ``value`` items exceed ``cap``."""
    if value > cap:
        raise InputError(f"{what}: {value} is more than the limit of {cap}")
