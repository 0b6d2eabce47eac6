"""The output canvas: what to keep of the placed elements, and the element density per kind.

* Fragments (exemplar elements cut by its border) are context for neighbourhoods only: a copy
  of one is kept only where it is cut by the output border the same way, never in the open.
* Elements entirely outside the canvas (or the domain) are dropped; those crossing it stay
  (``--clip`` clips them in the SVG).
* Density: each kind's count per area is brought to the exemplar's, estimated by minus
  sampling (whole elements / the area where a whole element of that size fits). Missing
  elements go to the emptiest spots (most clearance to all boxes), surplus ones leave where
  same-kind elements overlap most.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cvt.boxes import box_intersection
from cvt.free_spot import emptiest_spot
from cvt.torus import images, periodic_max

Placed = tuple[int, float, float]  # (element, dx, dy)
DENSITY_TOL = 0.05  # repair when a kind is off by more than this share
CANDIDATES = 600  # random spots tried per added element


def moved_boxes(placed: list[Placed], boxes: np.ndarray) -> np.ndarray:
    """Boxes of placed elements. Shape: (P, 4)."""
    if not placed:
        return np.zeros((0, 4))
    idx = np.array([p[0] for p in placed])
    d = np.array([[dx, dy, dx, dy] for _, dx, dy in placed])
    return boxes[idx] + d


def keep_on_canvas(placed: list[Placed], boxes: np.ndarray, cut: np.ndarray, out_box,
                   inside: Callable[[np.ndarray], np.ndarray] | None = None) -> list[Placed]:
    """Drop copies entirely off the canvas (or off ``inside``, a domain test on points (N, 2))
    and fragment copies that are not cut by the canvas border."""
    if not placed:
        return placed
    mb = moved_boxes(placed, boxes)
    x0, y0, x1, y1 = out_box
    eps = 1e-4 * max(x1 - x0, y1 - y0)
    touch = (mb[:, 0] < x1) & (mb[:, 2] > x0) & (mb[:, 1] < y1) & (mb[:, 3] > y0)
    crossing = ((mb[:, 0] < x0 + eps) | (mb[:, 1] < y0 + eps) | (mb[:, 2] > x1 - eps)
                | (mb[:, 3] > y1 - eps))
    frag = cut[[p[0] for p in placed]]
    keep = touch & (~frag | crossing)
    if inside is not None:
        keep &= _touches_domain(mb, inside)
    return [p for p, k in zip(placed, keep, strict=True) if k]


def _touches_domain(mb: np.ndarray, inside) -> np.ndarray:
    """Whether any of 25 points spread over each box is inside the domain. (P, 4) -> (P,)."""
    t = np.linspace(0, 1, 5)
    u, v = np.meshgrid(t, t)
    uv = np.c_[u.ravel(), v.ravel()]  # (25, 2)
    pts = mb[:, None, :2] + uv[None] * (mb[:, None, 2:] - mb[:, None, :2])  # (P, 25, 2)
    return inside(pts.reshape(-1, 2)).reshape(len(mb), -1).any(1)


def kind_rates(boxes: np.ndarray, kinds: np.ndarray, cut: np.ndarray, viewbox,
               shares: tuple[np.ndarray, np.ndarray] | None = None) -> dict[int, float]:
    """Whole elements centred on the canvas per area, for each kind; with ``shares`` (owner
    kind and weight per element, cvt.density.fragment_owners) the border's fragments count
    their share of the element they are a piece of."""
    from cvt.density import kind_counts

    x, y, w, h = viewbox
    owner, weight = shares if shares is not None else (np.where(cut, -1, kinds),
                                                       (~cut).astype(float))
    c = (boxes[:, :2] + boxes[:, 2:]) / 2
    n = kind_counts(np.arange(len(boxes)), c, owner, weight, (x, y, x + w, y + h))
    return {k: v / (w * h) for k, v in n.items() if v > 0}


def composites(boxes: np.ndarray, cut: np.ndarray, share: float = 0.1) -> list[list[int]]:
    """Whole elements that sit on or overlap each other (box intersection >= ``share`` of the
    smaller box), as groups in z order: a butterfly with its heart. Shape: boxes (E, 4)."""
    area = np.prod(boxes[:, 2:] - boxes[:, :2], axis=1)
    inter = box_intersection(boxes, boxes)
    near = inter >= share * np.minimum(area[:, None], area[None, :])  # (E, E)
    near &= ~cut[:, None] & ~cut[None, :]
    label = np.arange(len(boxes))
    for _ in range(len(boxes)):
        new = np.where(near, label[None, :], len(boxes)).min(1)
        new = np.minimum(new, label)
        if (new == label).all():
            break
        label = new
    groups: dict[int, list[int]] = {}
    for i in np.nonzero(~cut)[0]:
        groups.setdefault(int(label[i]), []).append(int(i))
    return list(groups.values())


def repair_density(placed: list[Placed], boxes: np.ndarray, kinds: np.ndarray,
                   rates: dict[int, float], groups: list[list[int]], out_box, area: float,
                   rng: np.random.Generator, inside=None, torus=None,
                   companions: dict[int, set[int]] | None = None) -> list[Placed]:
    """Add or remove copies so each kind has rate * area elements with their centre on the
    canvas (``area``: the canvas or domain area). Missing kinds are added as whole exemplar
    ``groups`` (composites, so a heart comes with its butterfly), each in the emptiest spot;
    new copies go just above their kind's last copy in the drawing order. On a ``torus``
    (tileable output, cvt.torus) clearances and overlaps wrap around the canvas. Copies in a
    companion pair (cvt.companions) are thinned only with their partners. A group is added
    or removed only while that lowers the largest relative error of its kinds (the border
    makes an exemplar show 13 flowers and 11 of their leaves: pairs settle between)."""
    placed = list(placed)
    want = {k: r * area for k, r in rates.items()}

    def missing() -> dict[int, float]:
        have = {k: _centred(placed, boxes, kinds, k, out_box, inside).sum() for k in want}
        return {k: want[k] - have[k] for k in want}

    gap = missing()
    for _ in range(int(sum(max(v, 0) for v in gap.values())) + 1):
        if not gap:
            break
        k = max(gap, key=gap.get)
        if gap[k] < max(0.5, DENSITY_TOL * want[k]):
            break
        options = [g for g in groups if any(kinds[e] == k for e in g)]
        group = options[int(rng.integers(len(options)))]
        if not _improves(gap, want, _counts(kinds[group])):
            break
        gb = boxes[group]
        spot = _emptiest(placed, boxes, np.r_[gb[:, :2].min(0), gb[:, 2:].max(0)], out_box,
                         rng, inside, torus)
        if spot is None:
            break
        for e in group:
            _insert(placed, (e, *spot), kinds)
            gap[int(kinds[e])] -= 1
    for k in want:
        gap = missing()
        if -gap[k] > max(0.5, DENSITY_TOL * want[k]):
            placed = _thin(placed, boxes, kinds, k, gap, want, out_box, inside, torus,
                           companions or {})
    return placed


def _counts(kk: np.ndarray) -> dict[int, int]:
    q, c = np.unique(kk, return_counts=True)
    return {int(a): int(b) for a, b in zip(q, c, strict=True)}


def _improves(gap: dict[int, float], want: dict[int, float], change: dict[int, int]) -> bool:
    """Whether changing the copies of some kinds by ``change`` (+ added, - removed) lowers the
    largest relative density error among them (``gap``: wanted - present, per kind)."""
    q = [k for k in change if want.get(k, 0) > 0]
    if not q:
        return False
    before = max(abs(gap[k]) / want[k] for k in q)
    return max(abs(gap[k] - change[k]) / want[k] for k in q) < before - 1e-9


def overlap_limits(boxes: np.ndarray, kinds: np.ndarray, cut: np.ndarray,
                   margin: float = 0.05) -> np.ndarray:
    """Largest box IoU of two whole exemplar elements, per kind pair, plus ``margin``.
    Shape: -> (K, K)."""
    from cvt.boxes import box_iou

    n = int(kinds.max()) + 1
    iou = box_iou(boxes, boxes)
    np.fill_diagonal(iou, 0)
    iou[cut] = iou[:, cut] = 0
    lim = np.zeros((n, n))
    np.maximum.at(lim, (kinds[:, None].repeat(len(kinds), 1), kinds[None].repeat(len(kinds), 0)),
                  iou)
    return lim + margin


def drop_overlaps(placed: list[Placed], boxes: np.ndarray, kinds: np.ndarray,
                  limits: np.ndarray, torus=None) -> list[Placed]:
    """Drop copies overlapping an earlier kept copy more than any two exemplar elements of
    those kinds overlap (stacked duplicates, clashes the exemplar never shows)."""
    from cvt.boxes import box_iou

    if len(placed) < 2:
        return placed
    mb = moved_boxes(placed, boxes)
    iou = periodic_max(box_iou, mb, mb, torus)
    kk = kinds[[p[0] for p in placed]]
    bad = iou > limits[kk[:, None], kk[None, :]]
    np.fill_diagonal(bad, False)
    keep = np.zeros(len(placed), bool)
    for i in range(len(placed)):
        keep[i] = not (bad[i] & keep).any()
    return [p for p, k in zip(placed, keep, strict=True) if k]


def _centres(placed: list[Placed], boxes: np.ndarray) -> np.ndarray:
    mb = moved_boxes(placed, boxes)
    return (mb[:, :2] + mb[:, 2:]) / 2


def _centred(placed, boxes, kinds, k, out_box, inside) -> np.ndarray:
    """Copies of kind k whose centre is on the canvas (and in the domain). Shape: (P,) bool."""
    if not placed:
        return np.zeros(0, bool)
    c = _centres(placed, boxes)
    x0, y0, x1, y1 = out_box
    on = (c[:, 0] >= x0) & (c[:, 0] < x1) & (c[:, 1] >= y0) & (c[:, 1] < y1)
    if inside is not None:
        on &= inside(c)
    return on & (kinds[[p[0] for p in placed]] == k)


def _emptiest(placed, boxes, box, out_box, rng, inside, torus=None
              ) -> tuple[float, float] | None:
    """Translation putting ``box`` where it overlaps the placed boxes least and, among such
    spots, has the most clearance to them (cvt.free_spot)."""
    x0, y0, x1, y1 = out_box
    centre = (box[:2] + box[2:]) / 2
    half = (box[2:] - box[:2]) / 2
    spots = rng.uniform([x0, y0], [x1, y1], size=(CANDIDATES, 2))  # (S, 2) centres
    if inside is not None:
        spots = spots[inside(spots)]
    if not len(spots):
        return None
    best = emptiest_spot(spots, half, images(moved_boxes(placed, boxes), torus)) if placed else 0
    d = spots[best] - centre
    return float(d[0]), float(d[1])


def _insert(placed: list[Placed], p: Placed, kinds: np.ndarray) -> None:
    last = max((i for i, q in enumerate(placed) if kinds[q[0]] == kinds[p[0]]), default=None)
    if last is None:  # above the copies of lower elements (input z order)
        last = max((i for i, q in enumerate(placed) if q[0] < p[0]), default=-1)
    placed.insert(last + 1, p)


def _thin(placed, boxes, kinds, k, gap, want, out_box, inside, torus=None,
          companions=None) -> list[Placed]:
    """Drop copies of kind k (centre on the canvas) that overlap same-kind copies most,
    elements touching others last, while that lowers the density error (:func:`_improves`;
    ``gap``: wanted - present per kind). A copy in a companion pair goes only with its
    partners (cvt.companions.pair_units)."""
    from cvt.companions import pair_units, touches

    on = np.nonzero(_centred(placed, boxes, kinds, k, out_box, inside))[0]
    mb = moved_boxes([placed[i] for i in on], boxes)
    inter = periodic_max(box_intersection, mb, mb, torus)
    np.fill_diagonal(inter, 0)
    all_mb = moved_boxes(placed, boxes)
    kk = kinds[[p[0] for p in placed]]
    hosting = touches(all_mb, torus=torus, cols=on).any(0)  # touching others: last
    unit = pair_units(all_mb, kk, companions, torus) if companions else np.arange(len(placed))
    gap = dict(gap)
    alive = np.ones(len(placed), bool)
    while True:
        score = (inter * alive[on][None]).sum(1) - 1e30 * hosting
        score[~alive[on]] = -np.inf
        for j in np.argsort(-score, kind="stable"):
            members = np.nonzero((unit == unit[on[j]]) & alive)[0]
            change = {q: -c for q, c in _counts(kk[members]).items()}
            if np.isfinite(score[j]) and _improves(gap, want, change):
                alive[members] = False
                for q, c in change.items():
                    gap[q] = gap.get(q, 0.0) - c
                break
        else:
            break
    return [p for p, a in zip(placed, alive, strict=True) if a]
