"""Methods to compare, by name: the full method, baselines and ablations (seed 000 sec. 7).

* ``full``: search, assignment, greedy clustering step, filtering, depth order.
* ``no-clustering``: fixed cluster ids (Ma et al. 2011-like), i.e. part 1 of this code base as
  shipped: no clustering step, no depth order or filtering, stacked copies dropped by the
  :func:`merge_duplicates` stopgap after the last level (this baseline's own step; the core
  loop does not know it).
* ``spectral``: the paper's comparison baseline (sec. 7.2): each clustering step is spectral
  clustering of the link-confidence graph into |O| / |I| * |{C_i}| clusters; reconstruction,
  filtering and depth order as in the full method.
* ``random``: input elements at random places, without overlaps, at the exemplar's density.
* ``no-features`` (w_f = 0), ``no-link`` (w_l = 0), ``no-shape`` (w_s = 0): Fig. 14 ablations.
"""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the CLI reads METHODS without paying for torch
    from cvt.reconstruction import Placement
    from cvt.svg import Exemplar
    from cvt.synthesis import SynthesisConfig, SynthesisResult

METHODS = ("full", "no-clustering", "spectral", "random", "no-features", "no-link", "no-shape")


def method_config(method: str, base: SynthesisConfig) -> SynthesisConfig:
    """``base`` changed as ``method`` needs (not for "random", which does not synthesize)."""
    replace = dataclasses.replace
    if method == "full":
        return base
    if method == "no-clustering":
        return replace(base, clustering="none", depth=False, filter_shapes=False)
    if method == "spectral":
        return replace(base, clustering="spectral")
    if method == "no-features":
        return replace(base, w_f=0.0)
    if method == "no-link":
        return replace(base, cluster=replace(base.cluster, w_l=0.0))
    if method == "no-shape":
        return replace(base, cluster=replace(base.cluster, w_s=0.0))
    raise ValueError(f"unknown method {method!r}; one of {', '.join(METHODS)}")


def run_method(method: str, exemplar: Exemplar, size: tuple[float, float],
               base: SynthesisConfig, on_iteration=None) -> SynthesisResult:
    from cvt.synthesis import synthesize

    if method == "random":
        return random_placement(exemplar, size, base.seed)
    res = synthesize(exemplar, size, method_config(method, base), on_iteration)
    if method == "no-clustering":
        boxes = np.stack([e.bbox for e in exemplar.elements])  # (E, 4)
        res.placements = merge_duplicates(res.placements, boxes)
    return res


def merge_duplicates(placements: list[Placement], boxes: np.ndarray,
                     floor: float = 0.15) -> list[Placement]:
    """Drop placements that overlap a better one more than any two input elements overlap.

    The no-clustering baseline's stopgap: clusters cut at patch borders each rebuild a whole
    element, stacking near-copies; the clustering step fixes the cause. ``boxes`` (E, 4) are
    the input elements' bounding boxes.
    """
    from cvt.boxes import box_iou

    if len(placements) < 2:
        return placements
    iou_in = box_iou(boxes, boxes)
    np.fill_diagonal(iou_in, 0)
    limit = max(floor, float(iou_in.max()) + 0.1)
    shift = np.array([[p.dx, p.dy, p.dx, p.dy] for p in placements])
    moved = boxes[[p.element for p in placements]] + shift  # (P, 4)
    iou = box_iou(moved, moved)
    kept = np.zeros(len(placements), dtype=bool)
    for k in np.argsort([p.energy for p in placements], kind="stable"):
        if not (iou[k, kept] > limit).any():
            kept[k] = True
    return [p for p, k in zip(placements, kept, strict=True) if k]


def random_placement(exemplar: Exemplar, size: tuple[float, float], seed: int = 0,
                     tries: int = 50) -> SynthesisResult:
    """Random input elements at random places with no two bounding boxes overlapping, as many
    per area as the exemplar has (fewer when the dart throwing runs out of ``tries`` per
    element). Drawn in input z order."""
    from cvt.reconstruction import Placement
    from cvt.synthesis import SynthesisResult

    t = time.perf_counter()
    rng = np.random.default_rng(seed)
    vx, vy, vw, vh = exemplar.viewbox
    boxes = np.stack([e.bbox for e in exemplar.elements])  # (E, 4)
    want = round(len(boxes) * size[0] * size[1] / (vw * vh))
    placed: list[np.ndarray] = []
    placements = []
    for _ in range(want * tries):
        if len(placements) == want:
            break
        e = int(rng.integers(len(boxes)))
        center = np.array([vx, vy]) + rng.uniform(0, 1, 2) * size
        shift = center - (boxes[e, :2] + boxes[e, 2:]) / 2
        box = boxes[e] + np.r_[shift, shift]
        if placed:
            other = np.stack(placed)
            hit = ((np.minimum(other[:, 2:], box[2:]) - np.maximum(other[:, :2], box[:2])) > 0)
            if hit.all(1).any():
                continue
        placed.append(box)
        placements.append(Placement(len(placements), e, float(shift[0]), float(shift[1]),
                                    0.0, e))
    placements.sort(key=lambda p: (p.z, p.cluster))
    res = SynthesisResult(placements, size, [], [])
    res.timings["init"] = time.perf_counter() - t
    return res
