"""Elements that sit on others (a butterfly on a heart, a ladybug on a shamrock) stay there.

In the exemplar, kind c is a companion of kind h when most c elements (``SHARE``) touch an h
element: their boxes share at least a tenth of the smaller box (so leaves around a flower are
companions of the flower, and the flower of its leaves). Neighbourhood synthesis can leave a
companion alone on the background; :func:`drop_orphans` removes those, and the density repair
(cvt.canvas) then adds whole exemplar composites (host with companion) where elements are
missing.
"""

from __future__ import annotations

import numpy as np

SHARE = 0.8


def touches(b: np.ndarray, share: float = 0.1) -> np.ndarray:
    """Boxes i and j share >= ``share`` of the smaller one (i != j). Shape: (N, 4) -> (N, N)."""
    area = np.prod(b[:, 2:] - b[:, :2], axis=1)
    inter = np.clip(np.minimum(b[:, None, 2:], b[None, :, 2:])
                    - np.maximum(b[:, None, :2], b[None, :, :2]), 0, None).prod(-1)
    out = inter >= share * np.minimum(area[:, None], area[None, :])
    np.fill_diagonal(out, False)
    return out


def companion_kinds(boxes: np.ndarray, kinds: np.ndarray, cut: np.ndarray) -> dict[int, int]:
    """companion kind -> host kind, from the exemplar. Shape: boxes (E, 4), kinds (E,)."""
    on = touches(boxes) & ~cut[None, :]
    out = {}
    for c in np.unique(kinds[~cut]):
        sel = np.nonzero((kinds == c) & ~cut)[0]
        for h in np.unique(kinds[~cut]):
            if h != c and on[np.ix_(sel, np.nonzero(kinds == h)[0])].any(1).mean() >= SHARE:
                out[int(c)] = int(h)
    return out


def drop_orphans(placed: list, boxes: np.ndarray, kinds: np.ndarray,
                 companions: dict[int, int]) -> list:
    """Remove placed companions that touch no element of their host kind."""
    if not companions or not placed:
        return placed
    from cvt.canvas import moved_boxes

    on = touches(moved_boxes(placed, boxes))
    kk = kinds[[p[0] for p in placed]]
    keep = np.ones(len(placed), bool)
    for i, k in enumerate(kk):
        if int(k) in companions:
            keep[i] = bool((on[i] & (kk == companions[int(k)])).any())
    return [p for p, k in zip(placed, keep, strict=True) if k]
