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

import torch
import torch.nn.functional as F
from scipy.optimize import linear_sum_assignment
from torch import Tensor

from neuraltex.nn_utils import argsort_last

_EPS = 1e-6


def instance_targets(labels: Tensor, max_segments: int) -> tuple[Tensor, Tensor]:
    """Label maps (B, H, W) int (0 = background, k = segment k) -> the segment index of every
    pixel among its image's largest ``max_segments`` labels (largest first; ``m`` = the most
    any image has, marks pixels of dropped labels), index (B, H*W) long in [0, m], and which
    of the m segments exist, valid (B, m) bool."""
    flat = labels.flatten(1)  # (B, P)
    order = []
    for lab in flat:
        ids, inverse, counts = torch.unique(lab, return_inverse=True, return_counts=True)
        rank = torch.empty_like(counts)
        rank[torch.argsort(counts, descending=True)] = torch.arange(len(counts))
        order.append((rank[inverse], min(len(ids), max_segments)))  # (P,) rank per pixel
    m = max(k for _, k in order)
    index = torch.stack([r.clamp_max(m) for r, _ in order])  # (B, P); >= k: dropped
    valid = torch.arange(m) < torch.tensor([k for _, k in order])[:, None]  # (B, m)
    index = torch.where(index < valid.sum(1, keepdim=True), index, m)
    return index, valid.to(labels.device)


def segment_sums(x: Tensor, index: Tensor, m: int) -> Tensor:
    """x (B, n, P) summed over the pixels of each segment: (B, n, m); index (B, P) in [0, m]
    (m: no segment). Equals x @ T^T for the binary target masks T (B, m, P) at O(n P) cost."""
    B, n, P = x.shape
    out = x.new_zeros(B, n, m + 1)
    return out.scatter_add(2, index[:, None].expand(B, n, P), x)[..., :m]


def pairwise_dice_bce(S: Tensor, index: Tensor, m: int) -> Tensor:
    """Dice + BCE cost between every query mask and target segment, the Hungarian
    assignment's costs (no gradient: :func:`matched_dice_bce` gives the matched entries with
    one). S (B, n, P) probs, index (B, P) segment of each pixel in [0, m]
    (:func:`instance_targets`) -> (B, n, m)."""
    with torch.no_grad():  # in place where it can: each (B, n, P) temporary is one pass
        inter = segment_sums(S, index, m)  # (B, n, m) = S @ T^T
        area = torch.zeros(index.shape[0], m + 1, dtype=S.dtype, device=S.device)
        area = area.scatter_add(1, index, torch.ones_like(index, dtype=S.dtype))[:, None, :m]
        dice = 1 - (2 * inter + 1) / (S.sum(-1, keepdim=True) + area + 1)
        log1ms = (1 - S).clamp_min_(_EPS).log_()
        log_ratio = S.clamp_min(_EPS).log_().sub_(log1ms)
        # sum_p [t log s + (1 - t) log(1 - s)]
        #   = sum_{p in T} (log s - log(1 - s)) + sum_p log(1 - s)
        bce = -(segment_sums(log_ratio, index, m) + log1ms.sum(-1, keepdim=True)) / S.shape[-1]
        return dice + bce


def matched_dice_bce(S: Tensor, index: Tensor, query: Tensor, m: int) -> Tensor:
    """The dice + BCE cost of each target segment against its matched query only, the entries
    of :func:`pairwise_dice_bce` the loss keeps, at O(m P) instead of O(n m P) cost with a
    gradient. S (B, n, P) probs, index (B, P) in [0, m], query (B, m) long, the query matched
    to each segment (any value for a segment that does not exist) -> (B, m)."""
    B, n, P = S.shape
    Sm = S.gather(1, query[:, :, None].expand(B, m, P))  # (B, m, P) each segment's query
    # each pixel lies in at most one segment: its own query's probability there, (B, P)
    own = torch.cat([query, query.new_zeros(B, 1)], 1).gather(1, index)  # (B, P)
    s = S.gather(1, own[:, None])[:, 0]  # (B, P)
    inside = index < m
    zero = s.new_zeros(B, m + 1)
    inter = zero.scatter_add(1, index, s * inside)[:, :m]  # (B, m)
    area = zero.scatter_add(1, index, inside.to(s.dtype))[:, :m]
    dice = 1 - (2 * inter + 1) / (Sm.sum(-1) + area + 1)
    log_ratio = torch.log(s.clamp_min(_EPS)) - torch.log((1 - s).clamp_min(_EPS))  # (B, P)
    log1ms = torch.log((1 - Sm).clamp_min(_EPS)).sum(-1)  # (B, m)
    bce = -(zero.scatter_add(1, index, log_ratio * inside)[:, :m] + log1ms) / P
    return dice + bce


def mask_supervision_loss(masks: Tensor, labels: Tensor, points: int | None = None,
                          generator: torch.Generator | None = None,
                          logits: bool = False) -> Tensor:
    """Hungarian-matched dice + BCE. masks (B, n, H, W) softmax over n; labels (B, H', W')
    integer segment maps (resized to H x W with nearest neighbour) -> scalar. ``points``:
    sample that many pixels per image (None or >= H*W: every pixel). ``logits``: ``masks``
    are the logits before that softmax, taken here on the sampled pixels only (the softmax
    is per pixel, so the loss is the same; with 1024 of 4096 pixels it skips 3/4 of it and
    of its backward).

    The costs of all images come from one batched product without a gradient; only the
    assignment runs per image (scipy), and the loss is computed again, with its gradient,
    for the matched pairs alone (the same numbers, and a backward over m instead of n x m
    pairs)."""
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
    costs = pairwise_dice_bce(S, index, m).cpu().numpy()  # (B, n, m)
    query = torch.zeros(B, m, dtype=torch.long)  # (B, m) the query of each segment
    unmatched = torch.ones(B, n, dtype=torch.bool)  # (B, n) queries with no segment
    for b, k in enumerate(valid.sum(1).tolist()):
        rows, cols = linear_sum_assignment(costs[b, :, :k])  # every segment gets a query
        query[b, torch.from_numpy(cols)] = torch.from_numpy(rows)
        unmatched[b, rows] = False
    query, unmatched = query.to(masks.device), unmatched.to(masks.device)
    cost = matched_dice_bce(S, index, query, m)  # (B, m)
    v = valid.to(S.dtype)
    matched_cost = (cost * v).sum(1) / v.sum(1)  # mean over each image's pairs
    u = unmatched.to(S.dtype)
    empty = (S.mean(-1) * u).sum(-1) / u.sum(-1).clamp_min(1)  # (B,)
    return (matched_cost + empty).mean()
