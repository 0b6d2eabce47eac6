"""A numpy ``Generator`` front end that serves scalar draws from a pre-drawn block.

Families draw a handful of scalars per texton; one ``rng.uniform()`` call costs a few
microseconds, which dominated rendering. Scalars now come from blocks of 1024
uniforms; array draws (``size=...``) go straight to the wrapped generator. The stream
is still a pure function of the seed, so samples stay deterministic.
"""

from __future__ import annotations

import math

import numpy as np

_BLOCK = 1024
_SMALL = 16


class Draws:
    """Wraps ``np.random.Generator``; same call signatures for what the families use."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng
        self._buf = np.empty(0)
        self._pos = 0

    def _next(self) -> float:
        if self._pos >= len(self._buf):
            self._buf = self.rng.random(_BLOCK).tolist()
            self._pos = 0
        self._pos += 1
        return self._buf[self._pos - 1]

    def _block(self, size) -> np.ndarray | None:
        """``size`` uniforms from the buffer when the request is small, else None."""
        n = int(np.prod(size))
        if n > _SMALL:
            return None
        return np.array([self._next() for _ in range(n)]).reshape(size)

    def uniform(self, low=0.0, high=1.0, size=None):
        if size is None:
            return low + (high - low) * self._next()
        u = self._block(size)
        if u is None:
            return self.rng.uniform(low, high, size)
        return low + (high - low) * u

    def integers(self, low, high=None, size=None):
        if size is not None:
            return self.rng.integers(low, high, size)
        lo, hi = (0, low) if high is None else (low, high)
        return lo + min(int(self._next() * (hi - lo)), hi - lo - 1)

    def normal(self, loc=0.0, scale=1.0, size=None):
        if size is None:
            return loc + scale * self._gauss()
        n = int(np.prod(size))
        if n > _SMALL:
            return self.rng.normal(loc, scale, size)
        return loc + scale * np.array([self._gauss() for _ in range(n)]).reshape(size)

    def _gauss(self) -> float:
        # Box-Muller from two buffered uniforms.
        u1, u2 = 1.0 - self._next(), self._next()
        return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)

    def __getattr__(self, name):  # random, shuffle, standard_normal, ...
        return getattr(self.rng, name)
