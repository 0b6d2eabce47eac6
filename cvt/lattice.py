"""Near-periodic exemplars: find the lattice and tile its cell (the default for regular patterns).

The seed's neighbourhood synthesis (seed 000) has no notion of a period: on a polka-dot grid it
makes patches with seams, holes and stacked copies. A lattice is two vectors a, b under which
(nearly) every element maps onto an element of its kind. Candidates are the offsets between
same-kind elements; a vector is a period when, of the elements whose translate lands on the
canvas (by its centre), at least ``MIN_SCORE`` find a same-kind element there (within ``tol``).
The cell's motifs are one representative per orbit (whole elements nearest the centre), and the
lattice is accepted only when it also predicts the exemplar: copies of the representatives
centred on the canvas exist in it, and every fragment cut by the border is part of such a copy.
With one period only (stripes whose elements span the canvas), the canvas side across it is the
second. Irregular exemplars fail these tests and go to the seed's method.

:func:`cell_copies` takes a lattice found elsewhere (neuraltex finds it on the picture of a
texture, whose element kinds are too fine to repeat exactly) and tiles the output with its
cells, each copied from a random whole cell of the exemplar.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

MIN_SCORE = 0.9
MIN_EXPLAINED = 0.85
MAX_CANDIDATES = 4000
PROBE = 48  # elements a candidate is first tried on
TOL = 0.2  # match distance, in nearest-neighbour distances (near-periodic: jitter allowed)
AXIS_CELLS = 16  # tileable output: lattice steps searched for a period along each canvas axis
AXIS_TOL = 0.02  # ... off the axis by at most this share of the shorter period


@dataclass(frozen=True)
class Lattice:
    a: np.ndarray  # (2,) first period, user units
    b: np.ndarray  # (2,) second period
    reps: np.ndarray  # (R,) element indices, one per motif of the cell, in z order
    explained: float  # share of the exemplar the lattice predicts

    @classmethod
    def given(cls, basis: np.ndarray) -> Lattice:
        """A lattice found elsewhere (rows a, b of ``basis`` (2, 2)), with no motifs of its own:
        for :func:`axis_periods` and :func:`cell_copies`."""
        a, b = np.asarray(basis, float)
        return cls(a, b, np.zeros(0, int), 1.0)


def _on_canvas(centers: np.ndarray, viewbox, margin: float) -> np.ndarray:
    """Centres at least ``margin`` inside the canvas. Shape: (N, 2) -> (N,) bool."""
    x, y, w, h = viewbox
    return ((centers[:, 0] >= x + margin) & (centers[:, 1] >= y + margin)
            & (centers[:, 0] <= x + w - margin) & (centers[:, 1] <= y + h - margin))


def _score(t, centers, kinds, viewbox, trees, tol) -> tuple[float, int]:
    """Share of the elements whose translate by t is centred on the canvas that meet their
    kind there."""
    ok = _on_canvas(centers + t, viewbox, tol)
    if not ok.any():
        return 0.0, 0
    hit = 0
    for k in np.unique(kinds[ok]):
        sel = ok & (kinds == k)
        d, _ = trees[k].query(centers[sel] + t, distance_upper_bound=tol)
        hit += int(np.isfinite(d).sum())
    return hit / ok.sum(), int(ok.sum())


def _candidates(centers, kinds, viewbox, tol) -> np.ndarray:
    """Offsets between same-kind elements, one per +/- pair, shortest first. Shape: (T, 2)."""
    mid = np.array([viewbox[0] + viewbox[2] / 2, viewbox[1] + viewbox[3] / 2])
    out = []
    for k in np.unique(kinds):
        idx = np.nonzero(kinds == k)[0]
        if len(idx) < 2:
            continue
        anchors = idx[np.argsort(np.linalg.norm(centers[idx] - mid, axis=1))[:8]]
        for a in anchors:
            out.append(centers[idx] - centers[a])
    if not out:
        return np.zeros((0, 2))
    t = np.concatenate(out)
    t = t[np.linalg.norm(t, axis=1) > 2 * tol]
    t[(t[:, 0] < -tol / 2) | ((np.abs(t[:, 0]) <= tol / 2) & (t[:, 1] < 0))] *= -1
    key = np.round(t / (tol / 2))
    _, first = np.unique(key, axis=0, return_index=True)
    t = t[first]
    return t[np.argsort(np.linalg.norm(t, axis=1), kind="stable")][:MAX_CANDIDATES]


def detect_lattice(centers: np.ndarray, kinds: np.ndarray, boxes: np.ndarray, whole: np.ndarray,
                   viewbox) -> Lattice | None:
    """The exemplar's lattice, or None. Shapes: centers (E, 2), kinds (E,), boxes (E, 4),
    whole (E,) bool (False for fragments cut by the border)."""
    w_idx = np.nonzero(whole)[0]
    if len(w_idx) < 4:
        return None
    c, k = centers[w_idx], kinds[w_idx]
    nn = cKDTree(c).query(c, k=2)[0][:, 1]
    tol = max(TOL * float(np.median(nn)), 1e-6 * max(viewbox[2:]))
    trees = {int(q): cKDTree(c[k == q]) for q in np.unique(k)}
    periods = []
    probe = np.linspace(0, len(c) - 1, min(PROBE, len(c))).astype(int)
    for t in _candidates(c, k, viewbox, tol):
        if len(c) > PROBE and _score(t, c[probe], k[probe], viewbox, trees,
                                     tol)[0] < MIN_SCORE - 0.15:
            continue
        t = _refine(t, c, k, trees, tol)
        score, n = _score(t, c, k, viewbox, trees, tol)
        if score >= MIN_SCORE and n >= max(3, 0.2 * len(c)):
            if not periods:
                periods.append(t)
            elif abs(_cross(periods[0], t)) >= 0.2 * np.linalg.norm(periods[0]) * np.linalg.norm(t):
                periods.append(t)
                break
    if not periods:
        return None
    if len(periods) == 1:  # stripes: elements span the canvas, which repeats as a whole
        sides = [np.array([viewbox[2], 0.0]), np.array([0.0, viewbox[3]])]
        periods.append(max(sides, key=lambda v: abs(_cross(periods[0], v)) / np.linalg.norm(v)))
    a, b = periods
    reps = _representatives(c, k, a, b, tol)
    if len(reps) > 0.5 * len(c):
        return None  # fewer than two copies per motif: not a repeating pattern
    lat = Lattice(a, b, np.sort(w_idx[reps]), 0.0)
    explained = _explained(lat, centers, kinds, boxes, whole, viewbox, tol)
    if explained < MIN_EXPLAINED:
        return None
    return Lattice(a, b, lat.reps, explained)


def _refine(t, c, k, trees, tol) -> np.ndarray:
    """The candidate moved to the mean offset of the pairs it matches (jitter averages out)."""
    offsets = []
    for q, tree in trees.items():
        sel = c[k == q]
        d, j = tree.query(sel + t, distance_upper_bound=tol)
        ok = np.isfinite(d)
        offsets.append(tree.data[j[ok]] - sel[ok])
    off = np.concatenate(offsets)
    return off.mean(0) if len(off) else t


def _cross(a: np.ndarray, b: np.ndarray) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _representatives(c, k, a, b, tol) -> np.ndarray:
    """One element per (kind, position in the cell), central ones first. Shape: (R,) indices."""
    basis = np.stack([a, b], axis=1)  # (2, 2), columns a, b
    inv = np.linalg.inv(basis)
    order = np.argsort(np.linalg.norm(c - c.mean(0), axis=1), kind="stable")
    reps: list[int] = []
    for i in order:
        for r in reps:
            if k[r] != k[i]:
                continue
            f = inv @ (c[i] - c[r])
            if np.linalg.norm(basis @ (f - np.round(f))) < tol:
                break
        else:
            reps.append(int(i))
    return np.array(reps, dtype=int)


def lattice_copies(lat: Lattice, boxes: np.ndarray, out_box) -> list[tuple[int, float, float]]:
    """(element, dx, dy) of every copy of the cell's motifs that touches ``out_box``, in z order
    of the motifs. Shape: boxes (E, 4)."""
    basis = np.stack([lat.a, lat.b], axis=1)
    inv = np.linalg.inv(basis)
    x0, y0, x1, y1 = out_box
    out = []
    for r in lat.reps:
        bx = boxes[r]
        lo = np.array([x0 - bx[2], y0 - bx[3]])  # translations that can touch the box
        hi = np.array([x1 - bx[0], y1 - bx[1]])
        corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]])
        f = corners @ inv.T  # (4, 2) lattice coordinates of the corners
        i0, j0 = np.floor(f.min(0)).astype(int)
        i1, j1 = np.ceil(f.max(0)).astype(int)
        ij = np.stack(np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1)), -1).reshape(-1, 2)
        shift = ij @ basis.T  # (M, 2)
        moved = bx[None] + np.c_[shift, shift]
        touch = ((moved[:, 0] < x1) & (moved[:, 2] > x0) & (moved[:, 1] < y1) & (moved[:, 3] > y0))
        out += [(int(r), float(s[0]), float(s[1])) for s in shift[touch]]
    return out


def axis_periods(lat: Lattice) -> tuple[Lattice, np.ndarray] | None:
    """The shortest lattice vectors along the canvas axes, (W, 0) and (0, H), and the lattice
    moved (by its jitter at most) so that they are exact: a tileable canvas of n W x m H then
    repeats the lattice without a step at the wrap. None when no lattice vector within
    AXIS_CELLS steps lies along an axis (an oblique lattice of irrational slope). Returns
    (lattice, (W, H)).

    On such a canvas :func:`lattice_copies` is a seamless tile as it is: it draws the plane's
    copies in the plane's order (by motif, then row and column, an order that translation
    keeps), and the plane repeats every W and H."""
    basis = np.stack([lat.a, lat.b])  # (2, 2), rows a, b
    r = np.arange(-AXIS_CELLS, AXIS_CELLS + 1)
    ij = np.stack(np.meshgrid(r, r), -1).reshape(-1, 2)  # (K, 2)
    v = ij @ basis  # (K, 2)
    tol = AXIS_TOL * min(np.linalg.norm(lat.a), np.linalg.norm(lat.b))
    steps = []
    for axis in (0, 1):
        along = (np.abs(v[:, 1 - axis]) <= tol) & (v[:, axis] > tol)
        if not along.any():
            return None
        steps.append(np.nonzero(along)[0][np.argmin(v[along, axis])])
    n = ij[steps].astype(float)  # (2, 2): (W, 0) = n[0] @ basis, (0, H) = n[1] @ basis
    period = np.array([v[steps[0], 0], v[steps[1], 1]])
    a, b = np.linalg.solve(n, np.diag(period))  # rows: the basis with those vectors exact
    return Lattice(a, b, lat.reps, lat.explained), period


def whole_periods(size, period) -> tuple[float, ...]:
    """``size`` moved to the nearest whole number (at least one) of ``period`` per axis."""
    return tuple(float(max(1, round(s / p)) * p) for s, p in zip(size, period, strict=True))


def _explained(lat: Lattice, centers, kinds, boxes, whole, viewbox, tol) -> float:
    """Share of predicted whole copies found in the exemplar and of fragments covered."""
    x, y, w, h = viewbox
    copies = lattice_copies(lat, boxes, (x, y, x + w, y + h))
    tree = cKDTree(centers[whole])
    kw = kinds[whole]
    found = total = 0
    for r, dx, dy in copies:
        if not _on_canvas(centers[r][None] + [dx, dy], viewbox, tol)[0]:
            continue
        total += 1
        hits = tree.query_ball_point(centers[r] + [dx, dy], tol)
        found += any(kw[j] == kinds[r] for j in hits)
    frag = np.nonzero(~whole)[0]
    if len(frag):
        moved = np.array([boxes[r] + np.array([dx, dy, dx, dy]) for r, dx, dy in copies])
        for f in frag:
            fb = boxes[f]
            inside = ((moved[:, 0] <= fb[0] + tol) & (moved[:, 1] <= fb[1] + tol)
                      & (moved[:, 2] >= fb[2] - tol) & (moved[:, 3] >= fb[3] - tol))
            total += 1
            found += bool(inside.any())
    return found / max(total, 1)


def cell_copies(basis: np.ndarray, centers: np.ndarray, boxes: np.ndarray, in_box, out_box,
                rng: np.random.Generator,
                torus: tuple[float, float] | None = None) -> list[tuple[int, float, float]] | None:
    """(element, dx, dy) of a plane tiled with the cells of a lattice, each cell's elements
    copied from a cell of the exemplar drawn at random (near-regular synthesis: the grid
    stays, the cells' content varies where the exemplar's cells differ), for every copy
    touching ``out_box``; None when the exemplar holds no whole cell. An element belongs to
    the cell its centre is in. ``torus`` = (W, H): the output wraps around with those
    periods, which must be lattice vectors (:func:`torus_cells`), and cells one period apart
    copy the same exemplar cell. Shapes: basis (2, 2) rows a, b; centers (E, 2); boxes
    (E, 4); boxes, ``in_box`` (the exemplar's canvas) and ``out_box`` as (x0, y0, x1, y1)."""
    inv = np.linalg.inv(basis.T)  # lattice coordinates of a point: inv @ p
    origin = _cell_origin(basis, in_box)
    if origin is None:
        return None
    cell = np.floor((centers - origin) @ inv.T).astype(int)  # (E, 2) cell of each element
    whole = _whole_cells(basis, origin, in_box)
    members = {c: np.nonzero((cell == c).all(1))[0] for c in whole}
    sources = [c for c in whole if len(members[c])]
    if not sources:
        return None
    reach = np.max(np.abs(boxes - np.c_[centers, centers]), axis=0)  # (4,) farthest extent
    x0, y0, x1, y1 = out_box
    corners = np.array([[x0 - reach[2], y0 - reach[3]], [x1 - reach[0], y0 - reach[3]],
                        [x0 - reach[2], y1 - reach[1]], [x1 - reach[0], y1 - reach[1]]])
    f = (corners - origin) @ inv.T  # (4, 2)
    lo, hi = np.floor(f.min(0)).astype(int) - 1, np.ceil(f.max(0)).astype(int) + 1
    wrap = None if torus is None else torus_cells(basis, torus)
    chosen: dict[tuple[int, int], tuple[int, int]] = {}
    out = []
    for i in range(lo[0], hi[0] + 1):
        for j in range(lo[1], hi[1] + 1):
            key = (i, j) if wrap is None else _canonical((i, j), wrap)
            if key not in chosen:
                chosen[key] = sources[int(rng.integers(len(sources)))]
            src = chosen[key]
            shift = (i - src[0]) * basis[0] + (j - src[1]) * basis[1]
            for e in members[src]:
                bx = boxes[e] + np.r_[shift, shift]
                if bx[0] < x1 and bx[2] > x0 and bx[1] < y1 and bx[3] > y0:
                    out.append((int(e), float(shift[0]), float(shift[1])))
    return out


def torus_cells(basis: np.ndarray, torus: tuple[float, float],
                tol: float = AXIS_TOL) -> np.ndarray | None:
    """The torus periods (W, 0) and (0, H) in whole lattice steps, rows, or None when either
    is not a lattice vector (within ``tol`` of a step). Shape: basis (2, 2) -> (2, 2) int."""
    inv = np.linalg.inv(basis.T)
    steps = inv @ np.array([[torus[0], 0.0], [0.0, torus[1]]])  # columns: the two periods
    whole = np.round(steps)
    if np.abs(steps - whole).max() > tol or abs(np.linalg.det(whole)) < 0.5:
        return None
    return whole.T.astype(int)


def _canonical(ij: tuple[int, int], wrap: np.ndarray) -> tuple[int, int]:
    """The cell ``ij`` moved by whole torus periods (rows of ``wrap``, integer lattice
    vectors) into their fundamental cell: one key per cell of the torus."""
    s = np.linalg.solve(wrap.T.astype(float), np.array(ij, float))
    k = np.floor(s + 1e-9).astype(int)
    return tuple(int(v) for v in np.array(ij) - k @ wrap)


def _whole_cells(basis: np.ndarray, origin: np.ndarray, box) -> list[tuple[int, int]]:
    """Cells (i, j) whose parallelogram origin + [i, i+1) a + [j, j+1) b lies in ``box``."""
    x0, y0, x1, y1 = box
    inv = np.linalg.inv(basis.T)
    corners = np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1]])
    f = (corners - origin) @ inv.T
    lo, hi = np.floor(f.min(0)).astype(int), np.ceil(f.max(0)).astype(int)
    unit = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], float)
    eps = 1e-6 * max(x1 - x0, y1 - y0)
    out = []
    for i in range(lo[0], hi[0] + 1):
        for j in range(lo[1], hi[1] + 1):
            p = origin + (unit + [i, j]) @ basis  # (4, 2) corners of the cell
            if (p[:, 0].min() >= x0 - eps and p[:, 0].max() <= x1 + eps
                    and p[:, 1].min() >= y0 - eps and p[:, 1].max() <= y1 + eps):
                out.append((i, j))
    return out


def _cell_origin(basis: np.ndarray, box, steps: int = 4) -> np.ndarray | None:
    """The cell grid's origin, among ``steps`` x ``steps`` offsets inside one cell, that
    leaves the most whole cells in ``box`` (the first on ties); None when none does."""
    best, most = None, 0
    for u in range(steps):
        for v in range(steps):
            origin = np.array(box[:2], float) + (u / steps) * basis[0] + (v / steps) * basis[1]
            n = len(_whole_cells(basis, origin, box))
            if n > most:
                best, most = origin, n
    return best
