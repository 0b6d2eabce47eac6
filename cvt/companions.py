"""Elements that sit on others (a butterfly on a heart, a ladybug on a shamrock) stay there.

In the exemplar, kind c is a companion of kind h when most c elements (``SHARE``) touch an h
element: their boxes share at least a tenth of the smaller box (so leaves around a flower are
companions of the flower, and the flower of each kind of its leaves). Neighbourhood synthesis
can leave a companion without one of its hosts; :func:`drop_orphans` removes those (and then
the companions that only they hosted), the density repair (cvt.canvas) adds whole exemplar
composites (host with companions) where elements are missing, and never thins an element
out of a pair (it thins whole :func:`pair_units`).
"""

from __future__ import annotations

import numpy as np

SHARE = 0.8


def touches(b: np.ndarray, share: float = 0.1, torus=None,
            cols: np.ndarray | None = None) -> np.ndarray:
    """Boxes i and j share >= ``share`` of the smaller one (i != j; on a ``torus``, cvt.torus,
    across the seam too); with ``cols``, only the columns j in ``cols``.
    Shape: (N, 4) -> (N, N), or (N, C) for cols (C,)."""
    from cvt.boxes import box_touch
    from cvt.torus import periodic_max

    cols = np.arange(len(b)) if cols is None else np.asarray(cols)
    out = periodic_max(lambda p, q: box_touch(p, q, share), b, b[cols], torus)
    out[cols, np.arange(len(cols))] = False
    return out


def companion_kinds(boxes: np.ndarray, kinds: np.ndarray,
                    cut: np.ndarray) -> dict[int, set[int]]:
    """companion kind -> its host kinds, from the exemplar. Shape: boxes (E, 4), kinds (E,)."""
    on = touches(boxes) & ~cut[None, :]
    out: dict[int, set[int]] = {}
    for c in np.unique(kinds[~cut]):
        sel = np.nonzero((kinds == c) & ~cut)[0]
        for h in np.unique(kinds[~cut]):
            if h != c and on[np.ix_(sel, np.nonzero(kinds == h)[0])].any(1).mean() >= SHARE:
                out.setdefault(int(c), set()).add(int(h))
    return out


def drop_orphans(placed: list, boxes: np.ndarray, kinds: np.ndarray,
                 companions: dict[int, set[int]], torus=None) -> list:
    """Remove placed companions that touch no element of one of their host kinds, until
    none is left (a dropped flower orphans its leaves)."""
    if not companions or not placed:
        return placed
    from cvt.canvas import moved_boxes

    on = touches(moved_boxes(placed, boxes), torus=torus)
    kk = kinds[[p[0] for p in placed]]
    keep = np.ones(len(placed), bool)
    while True:
        ok = np.array([all((on[i] & keep & (kk == h)).any() for h in companions.get(int(k), ()))
                       for i, k in enumerate(kk)])
        if (keep <= ok).all():
            break
        keep &= ok
    return [p for p, k in zip(placed, keep, strict=True) if k]


def pair_units(mb: np.ndarray, kk: np.ndarray, companions: dict[int, set[int]],
               torus=None) -> np.ndarray:
    """Component label per placed element: copies joined by companion touches (a flower with
    its leaves) share one, lone copies have their own. Shape: mb (P, 4) boxes, kk (P,)
    kinds -> (P,) long."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    on = touches(mb, torus=torus)
    pair = np.zeros_like(on)
    for c, hosts in companions.items():
        for h in hosts:
            link = (kk[:, None] == c) & (kk[None, :] == h)
            pair |= link | link.T
    return connected_components(csr_matrix(on & pair), directed=False)[1]
