"""Optional mask supervision (``loss.mask_supervision: gt | pseudo``).

Mask2Former's set criterion, written small: each target segment (the ground-truth texton
instances, or Felzenszwalb segments for ``pseudo``; the background counts as one segment) is
matched to one query by the Hungarian algorithm on a dice + BCE cost, then the matched pairs
are pulled together with the same dice + BCE, and unmatched queries are pushed towards empty
masks. Masks are the softmax-normalized S of the segmentation head.

With ``points`` the costs and the loss are computed on that many uniformly sampled pixels per
image instead of all of them (Mask2Former's point-sampled loss, Cheng et al. 2022, 3.3: it
trains on 112 x 112 sampled points), the same pixels for every query of an image.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch
import torch.nn.functional as F
from scipy.optimize import linear_sum_assignment
from torch import Tensor

from neuraltex.nn_utils import argsort_last

_EPS = 1e-6


def instance_targets(labels: Tensor, max_segments: int) -> tuple[Tensor, Tensor]:
    """Label maps (B, H, W) int (0 = background, k = segment k) -> the segment index of every
    pixel among its image's largest ``max_segments`` labels (largest first, equal sizes by
    label; ``m`` = the most any image has, marks pixels of dropped labels), index (B, H*W)
    long in [0, m], and which of the m segments exist, valid (B, m) bool. One sort for the
    whole batch (numpy's)."""
    flat = labels.flatten(1).cpu().numpy().astype(np.int64)  # (B, P)
    B = flat.shape[0]
    lo, span = flat.min(), int(flat.max() - flat.min()) + 1
    ids, inverse, counts = np.unique(flat - lo + span * np.arange(B)[:, None],
                                     return_inverse=True, return_counts=True)
    image = ids // span  # (K,) the image of each (image, label) pair, ascending
    order = np.lexsort((ids, -counts, image))  # by image, then largest first, then label
    first = np.searchsorted(image, np.arange(B))  # (B,) where each image's pairs start
    rank = np.empty_like(order)
    rank[order] = np.arange(len(ids)) - first[image[order]]  # (K,) rank within its image
    k = np.minimum(np.bincount(image, minlength=B), max_segments)  # (B,) segments kept
    m = int(k.max())
    rank = rank[inverse.reshape(flat.shape)]  # (B, P)
    index = np.where(rank < k[:, None], rank, m)
    valid = np.arange(m) < k[:, None]  # (B, m)
    return (torch.from_numpy(index).to(labels.device),
            torch.from_numpy(valid).to(labels.device))


def segment_sums(x: Tensor, index: Tensor, m: int) -> Tensor:
    """x (B, n, P) summed over the pixels of each segment: (B, n, m); index (B, P) in [0, m]
    (m: no segment). Equals x @ T^T for the binary target masks T (B, m, P) at O(n P) cost."""
    B, n, P = x.shape
    out = x.new_zeros(B, n, m + 1)
    return out.scatter_add(2, index[:, None].expand(B, n, P), x)[..., :m]


class SegmentStats(NamedTuple):
    """The sums over pixels that a dice + BCE cost of a (query, segment) pair is made of, for
    every pair, without gradient (:func:`segment_stats`). B images, n queries, m segments."""

    inter: Tensor      # (B, n, m) sum of S over the segment's pixels (S @ T^T)
    mass: Tensor       # (B, n) sum of S over all pixels
    area: Tensor       # (B, 1, m) pixels in the segment
    log_ratio: Tensor  # (B, n, m) sum over the segment of log S - log(1 - S), each clamped
    log1ms: Tensor     # (B, n) sum over all pixels of log(1 - S), clamped
    pixels: int        # P

    def costs(self) -> Tensor:
        """Dice + BCE of every (query, segment) pair, (B, n, m)."""
        dice = 1 - (2 * self.inter + 1) / (self.mass[..., None] + self.area + 1)
        # sum_p [t log s + (1 - t) log(1 - s)]
        #   = sum_{p in T} (log s - log(1 - s)) + sum_p log(1 - s)
        return dice - (self.log_ratio + self.log1ms[..., None]) / self.pixels


def segment_stats(S: Tensor, index: Tensor, m: int) -> SegmentStats:
    """S (B, n, P) probs, index (B, P) segment of each pixel in [0, m]
    (:func:`instance_targets`) -> the sums of :class:`SegmentStats`, no gradient."""
    with torch.no_grad():  # in place where it can: each (B, n, P) temporary is one pass
        area = torch.zeros(index.shape[0], m + 1, dtype=S.dtype, device=S.device)
        area = area.scatter_add(1, index, torch.ones_like(index, dtype=S.dtype))[:, None, :m]
        log1ms = (1 - S).clamp_min_(_EPS).log_()
        log_ratio = S.clamp_min(_EPS).log_().sub_(log1ms)
        return SegmentStats(segment_sums(S, index, m), S.sum(-1), area,
                            segment_sums(log_ratio, index, m), log1ms.sum(-1), S.shape[-1])


def pairwise_dice_bce(S: Tensor, index: Tensor, m: int) -> Tensor:
    """Dice + BCE cost between every query mask and target segment, the Hungarian
    assignment's costs (no gradient). S (B, n, P) probs, index (B, P) segment of each pixel
    in [0, m] (:func:`instance_targets`) -> (B, n, m)."""
    return segment_stats(S, index, m).costs()


class _MatchedLoss(torch.autograd.Function):
    """The loss of :func:`mask_supervision_loss` from the assignment and the pairs' sums
    (:class:`SegmentStats`), with its gradient in closed form: for query i matched to
    segment j of image b (weight w = 1 / (B * segments of b)), D = mass_i + area_j + 1,

        d cost / d S_ip = w [(2 I_ij + 1) / D^2 + 1 / (P (1 - S_ip))]             p not in j
                        = w [(2 I_ij + 1) / D^2 - 2 / D - 1 / (P S_ip)]           p in j

    (each 1 / x zero where its clamp at eps cut x), and 1 / (B P unmatched_b) for an
    unmatched query: two passes over (B, n, P) where autograd through the gathered pairs took
    about ten, with a scatter of each gather."""

    @staticmethod
    def forward(ctx, S: Tensor, stats: SegmentStats, index: Tensor, query: Tensor,
                unmatched: Tensor, valid: Tensor) -> Tensor:
        B, n, P = S.shape
        inter = stats.inter.gather(1, query[:, None])[:, 0]  # (B, m) each segment's pair
        D = stats.mass.gather(1, query) + stats.area[:, 0] + 1  # (B, m)
        ratio = stats.log_ratio.gather(1, query[:, None])[:, 0]
        cost = 1 - (2 * inter + 1) / D - (ratio + stats.log1ms.gather(1, query)) / P
        v, u = valid.to(S.dtype), unmatched.to(S.dtype)
        w = v / (B * v.sum(1, keepdim=True))  # (B, m) the weight of each pair in the loss
        e = u / (B * P * u.sum(1, keepdim=True).clamp_min(1))  # (B, n) of each mask pixel
        ctx.save_for_backward(S, index, query, inter, D, w, e)
        return (cost * w).sum() + (stats.mass * e).sum()

    @staticmethod
    def backward(ctx, grad: Tensor):
        S, index, query, inter, D, w, e = ctx.saved_tensors
        B, n, P = S.shape
        m = query.shape[1]
        # per segment (B, m): the dice terms, then the BCE's 1/P, onto their queries' rows;
        # pairs of segments that do not exist have w = 0 and add nothing
        a = w * (2 * inter + 1) / D ** 2
        row_a = e.scatter_add(1, query, a)  # (B, n)
        row_c = torch.zeros_like(e).scatter_add(1, query, w / P)
        one = 1 - S
        far = one.clamp_min(_EPS).reciprocal_().masked_fill_(one < _EPS, 0)
        G = far.mul_(row_c[..., None]).add_(row_a[..., None])  # (B, n, P), p in no pair
        # each pixel of a segment: the entry of its segment's query, (B, P)
        inside = index < m
        seg = index.clamp_max(m - 1)
        own = query.gather(1, seg)  # (B, P) the row whose segment holds p
        s = S.gather(1, own[:, None])[:, 0]
        near = s.clamp_min(_EPS).reciprocal().masked_fill_(s < _EPS, 0)
        at = lambda t: t.gather(1, seg)  # noqa: E731  (B, m) -> (B, P)
        value = at(a) - at(2 * w / D) - at(w / P) * near
        value = torch.where(inside, value, G.gather(1, own[:, None])[:, 0])
        G.scatter_(1, own[:, None], value[:, None])
        return G.mul_(grad), None, None, None, None, None


def mask_supervision_loss(masks: Tensor, labels: Tensor, points: int | None = None,
                          generator: torch.Generator | None = None,
                          logits: bool = False) -> Tensor:
    """Hungarian-matched dice + BCE. masks (B, n, H, W) softmax over n; labels (B, H', W')
    integer segment maps (resized to H x W with nearest neighbour) -> scalar. ``points``:
    sample that many pixels per image (None or >= H*W: every pixel). ``logits``: ``masks``
    are the logits before that softmax, taken here on the sampled pixels only (the softmax
    is per pixel, so the loss is the same; with 1024 of 4096 pixels it skips 3/4 of it and
    of its backward).

    The costs of all images come from one batched pass without a gradient
    (:func:`segment_stats`); only the assignment runs per image (scipy). The loss reads the
    matched pairs' costs from the same sums, and its gradient is written in closed form
    (:class:`_MatchedLoss`): the same numbers as autograd through the matched pairs, in two
    passes over the masks instead of about ten."""
    if masks.dtype in (torch.bfloat16, torch.float16):  # autocast (trainer.amp): the loss in
        masks = masks.float()                            # float32 (float64 stays float64)
    B, n, H, W = masks.shape
    if labels.shape[-2:] != (H, W):
        labels = F.interpolate(labels[:, None].float(), size=(H, W), mode="nearest")[:, 0]
    index, valid = instance_targets(labels.long().to(masks.device), n)  # (B, P), (B, m)
    S = masks.reshape(B, n, H * W)
    if points and points < H * W:
        pick = argsort_last(torch.rand(B, H * W, generator=generator))[:, :points]  # (B, k)
        pick = pick.to(masks.device)
        S, index = S.gather(-1, pick[:, None].expand(B, n, points)), index.gather(-1, pick)
    if logits:
        S = S.softmax(dim=1)
    m = valid.shape[1]
    stats = segment_stats(S.detach(), index, m)
    costs = stats.costs().cpu().numpy()  # (B, n, m)
    query = np.zeros((B, m), dtype=np.int64)  # (B, m) the query of each segment
    unmatched = np.ones((B, n), dtype=bool)  # (B, n) queries with no segment
    for b, k in enumerate(valid.sum(1).tolist()):
        rows, cols = linear_sum_assignment(costs[b, :, :k])  # every segment gets a query
        query[b, cols] = rows
        unmatched[b, rows] = False
    return _MatchedLoss.apply(S, stats, index, torch.from_numpy(query).to(S.device),
                              torch.from_numpy(unmatched).to(S.device), valid)
