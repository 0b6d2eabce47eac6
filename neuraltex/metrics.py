"""Texton extraction quality against ground-truth instance masks.

Predictions are label maps (any integers; a label is one predicted segment, there is
no special background label), so every method can be scored. Ground truth: 0 =
background, 1..K = textons. Metrics:

- :func:`matched_miou` (headline): Hungarian matching of GT textons to predicted
  segments on IoU, averaged over GT textons (an unmatched texton scores 0).
- :func:`foreground_ari`: adjusted Rand index on GT-foreground pixels. A fixed spatial
  partition already scores ~0.6 on separated objects; never read it alone.
- :func:`count_error`: |pred - gt| / gt, where the predicted count is the number of
  segments that lie mostly (> 50 % of their pixels) on GT foreground.
- :func:`boundary_f1`: F-measure of boundary pixels matched within a tolerance
  (BSDS default: 0.75 % of the image diagonal).
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.optimize import linear_sum_assignment

METRICS = ("miou", "ari", "count_err", "boundary_f1")


def _check(pred: np.ndarray, gt: np.ndarray) -> None:
    if pred.shape != gt.shape or pred.ndim != 2:
        raise ValueError(f"pred and gt must be (H, W) of the same shape, got {pred.shape}, "
                         f"{gt.shape}")


def contingency(pred: np.ndarray, gt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel counts of every (gt label, pred segment) pair.

    Shape: (H, W), (H, W) -> table (G, P) int64 where rows follow the sorted GT labels
    (row 0 is background when present) and columns the sorted pred labels; also
    returns the GT labels (G,).
    """
    _check(pred, gt)
    g_labels, g = np.unique(gt.ravel(), return_inverse=True)
    _, p = np.unique(pred.ravel(), return_inverse=True)
    n_p = int(p.max()) + 1
    table = np.bincount(g * n_p + p, minlength=len(g_labels) * n_p)
    return table.reshape(len(g_labels), n_p), g_labels


def iou_matrix(pred: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """IoU of every GT texton (rows, labels 1..K in sorted order) with every pred segment."""
    table, g_labels = contingency(pred, gt)
    area_p = table.sum(0)  # (P,)
    table = table[g_labels > 0]  # (K, P) textons only
    area_g = table.sum(1, keepdims=True)  # (K, 1)
    union = area_g + area_p[None, :] - table
    return table / np.maximum(union, 1)


def matched_miou(pred: np.ndarray, gt: np.ndarray) -> float:
    """Hungarian-matched mean IoU over GT textons; nan when GT has no texton."""
    iou = iou_matrix(pred, gt)
    if iou.shape[0] == 0:
        return float("nan")
    rows, cols = linear_sum_assignment(-iou)
    return float(iou[rows, cols].sum() / iou.shape[0])


def adjusted_rand_index(a: np.ndarray, b: np.ndarray) -> float:
    """ARI between two labelings of the same items (1D arrays); 1.0 when both are trivial."""
    _, ia = np.unique(a, return_inverse=True)
    _, ib = np.unique(b, return_inverse=True)
    nb = int(ib.max()) + 1 if ib.size else 1
    table = np.bincount(ia * nb + ib).astype(np.float64)
    pairs = lambda x: (x * (x - 1) / 2.0).sum()  # noqa: E731
    index = pairs(table)
    sum_a = pairs(np.bincount(ia).astype(np.float64))
    sum_b = pairs(np.bincount(ib).astype(np.float64))
    total = a.size * (a.size - 1) / 2.0
    expected = sum_a * sum_b / total if total > 0 else 0.0
    maximum = 0.5 * (sum_a + sum_b)
    if maximum == expected:
        return 1.0
    return float((index - expected) / (maximum - expected))


def foreground_ari(pred: np.ndarray, gt: np.ndarray) -> float:
    """ARI restricted to GT-foreground pixels; nan when GT has no texton."""
    _check(pred, gt)
    fg = gt > 0
    if not fg.any():
        return float("nan")
    return adjusted_rand_index(gt[fg], pred[fg])


def predicted_count(pred: np.ndarray, gt: np.ndarray) -> int:
    """Number of pred segments with more than half of their pixels on GT foreground."""
    table, g_labels = contingency(pred, gt)
    on_fg = table[g_labels > 0].sum(0)
    return int((on_fg * 2 > table.sum(0)).sum())


def count_error(pred: np.ndarray, gt: np.ndarray, count: int | None = None) -> float:
    """|pred count - gt count| / gt count. ``count`` overrides the predicted count
    (for methods that report their own, e.g. existing textons)."""
    k = len(np.unique(gt[gt > 0]))
    if k == 0:
        return float("nan")
    n = predicted_count(pred, gt) if count is None else count
    return abs(n - k) / k


def boundaries(labels: np.ndarray) -> np.ndarray:
    """Pixels with a 4-neighbour of a different label. Shape: (H, W) -> (H, W) bool."""
    b = np.zeros(labels.shape, bool)
    dx = labels[:, 1:] != labels[:, :-1]
    dy = labels[1:, :] != labels[:-1, :]
    b[:, 1:] |= dx
    b[:, :-1] |= dx
    b[1:, :] |= dy
    b[:-1, :] |= dy
    return b


def boundary_f1(pred: np.ndarray, gt: np.ndarray, tolerance: float | None = None) -> float:
    """F1 of boundary pixels matched within ``tolerance`` px (default 0.75 % of diagonal)."""
    _check(pred, gt)
    if tolerance is None:
        tolerance = max(1.0, round(0.0075 * float(np.hypot(*gt.shape))))
    bp, bg = boundaries(pred), boundaries(gt)
    if not bp.any() and not bg.any():
        return 1.0
    if not bp.any() or not bg.any():
        return 0.0
    precision = (distance_transform_edt(~bg)[bp] <= tolerance).mean()
    recall = (distance_transform_edt(~bp)[bg] <= tolerance).mean()
    if precision + recall == 0:
        return 0.0
    return float(2 * precision * recall / (precision + recall))


def texton_scores(pred: np.ndarray, gt: np.ndarray) -> dict[str, float]:
    """All metrics of one prediction: keys ``METRICS``."""
    return dict(miou=matched_miou(pred, gt), ari=foreground_ari(pred, gt),
                count_err=count_error(pred, gt), boundary_f1=boundary_f1(pred, gt))
