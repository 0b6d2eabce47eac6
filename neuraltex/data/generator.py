"""One procedural texture sample: image, instance mask and metadata from (seed, index).

Content is defined in normalized coordinates (short side = 1), so the same (seed, index)
renders the same texture at any resolution; only per-pixel sensor noise differs.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from neuraltex.data.draws import Draws
from neuraltex.data.families import FAMILIES, FAMILY_NAMES
from neuraltex.errors import InputError

MIN_SIZE, MAX_SIZE = 8, 4096


@dataclass
class Sample:
    """A generated texture.

    image: (H, W, 3) float32 in [0, 1]. mask: (H, W) int32, 0 = background, 1..K textons
    (ids in painting order, back to front, for overlapping families). centers: (K, 2)
    float32 mask centroids in normalized coords (x, y; short side 1), row k-1 for texton k.
    """

    image: np.ndarray
    mask: np.ndarray
    family: str
    hard: bool
    seed: int
    index: int
    params: dict = field(default_factory=dict)

    @functools.cached_property
    def centers(self) -> np.ndarray:
        return mask_centers(self.mask)

    @property
    def count(self) -> int:
        return int(self.mask.max())

    def meta(self) -> dict:
        """JSON-friendly metadata."""
        return dict(family=self.family, hard=self.hard, seed=self.seed, index=self.index,
                    count=self.count, height=self.mask.shape[0], width=self.mask.shape[1],
                    params={k: _plain(v) for k, v in self.params.items()},
                    centers=np.round(self.centers.astype(np.float64), 5).tolist())


def sample_rng(seed: int, index: int) -> Draws:
    """The generator every draw of sample (seed, index) comes from."""
    return Draws(np.random.default_rng([int(seed), int(index)]))


def generate(index: int, seed: int = 0, size: int | tuple[int, int] = 128,
             family: str | None = None) -> Sample:
    """Render sample ``index`` of stream ``seed`` at ``size`` (side or (H, W)).

    ``family`` forces a family (see ``FAMILY_NAMES``); by default it is drawn from the
    sample's own generator, uniformly over families.
    """
    h, w = (size, size) if np.isscalar(size) else (int(size[0]), int(size[1]))
    if not (MIN_SIZE <= h <= MAX_SIZE and MIN_SIZE <= w <= MAX_SIZE):
        raise InputError(f"size must be between {MIN_SIZE} and {MAX_SIZE} px, got {h}x{w}")
    if index < 0 or seed < 0:
        raise InputError(f"seed and index must be >= 0, got seed={seed} index={index}")
    rng = sample_rng(seed, index)
    pick = FAMILY_NAMES[int(rng.integers(len(FAMILY_NAMES)))]
    name = pick if family is None else family
    if name not in FAMILIES:
        raise InputError(f"unknown family {name!r}; choose from {', '.join(FAMILY_NAMES)}")
    fam = FAMILIES[name]
    image, ids, params = fam.render(rng, h, w)
    mask = relabel(ids)
    return Sample(np.clip(image, 0.0, 1.0).astype(np.float32), mask, name, fam.hard,
                  int(seed), int(index), params)


def relabel(ids: np.ndarray) -> np.ndarray:
    """Map raw ids to 0 (background stays 0) and 1..K, keeping their order.

    Painter ids grow back to front, so texton k+1 lies above texton k where they overlap.
    """
    flat = ids.ravel()
    if flat.size and (flat.min() < 0 or flat.max() > 16 * flat.size):
        _, flat = np.unique(flat, return_inverse=True)  # sparse ids: compact first
        flat = flat + (1 if ids.min() > 0 else 0)
    present = np.bincount(flat) > 0
    present[0] = False
    lut = np.cumsum(present) * present  # raw id -> 1..K, absent/background -> 0
    return lut[flat].reshape(ids.shape).astype(np.int32)


def mask_centers(mask: np.ndarray) -> np.ndarray:
    """Centroids of ids 1..K in normalized coords. Shape: (H, W) -> (K, 2) (x, y)."""
    k = int(mask.max())
    s = min(mask.shape)
    ii, jj = np.indices(mask.shape)
    flat = mask.ravel()
    area = np.bincount(flat, minlength=k + 1)[1:].astype(np.float64)
    cx = np.bincount(flat, weights=(jj.ravel() + 0.5) / s, minlength=k + 1)[1:]
    cy = np.bincount(flat, weights=(ii.ravel() + 0.5) / s, minlength=k + 1)[1:]
    area = np.maximum(area, 1.0)
    return np.stack([cx / area, cy / area], -1).astype(np.float32)


def _plain(v):
    if isinstance(v, np.generic):
        return v.item()
    return v
