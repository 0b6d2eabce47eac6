"""Optional mask supervision (``loss.mask_supervision: gt | pseudo``).

Mask2Former's set criterion, written small: each target segment (the ground-truth texton
instances, or Felzenszwalb segments for ``pseudo``; the background counts as one segment) is
matched to one query by the Hungarian algorithm on a dice + BCE cost, then the matched pairs
are pulled together with the same dice + BCE, and unmatched queries are pushed towards empty
masks. Masks are the softmax-normalized S of the segmentation head.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from scipy.optimize import linear_sum_assignment
from torch import Tensor

_EPS = 1e-6


def instance_targets(labels: Tensor, max_segments: int) -> list[Tensor]:
    """Label maps (B, H, W) int (0 = background, k = segment k) -> per image (m, H*W) binary
    masks of the present labels, the largest ``max_segments`` kept."""
    out = []
    for lab in labels.flatten(1):
        ids, counts = torch.unique(lab, return_counts=True)
        ids = ids[torch.argsort(counts, descending=True)[:max_segments]]
        out.append((lab.unsqueeze(0) == ids.unsqueeze(1)).to(torch.float32))
    return out


def pairwise_dice_bce(S: Tensor, T: Tensor) -> Tensor:
    """Cost between every query mask and target mask. S (n, P) probs, T (m, P) binary -> (n, m)."""
    T = T.to(S.dtype)
    inter = S @ T.T
    dice = 1 - (2 * inter + 1) / (S.sum(-1, keepdim=True) + T.sum(-1).unsqueeze(0) + 1)
    logs, log1ms = torch.log(S.clamp_min(_EPS)), torch.log((1 - S).clamp_min(_EPS))
    bce = -(logs @ T.T + log1ms @ (1 - T).T) / S.shape[-1]
    return dice + bce


def mask_supervision_loss(masks: Tensor, labels: Tensor) -> Tensor:
    """Hungarian-matched dice + BCE. masks (B, n, H, W) softmax over n; labels (B, H', W')
    integer segment maps (resized to H x W with nearest neighbour) -> scalar."""
    B, n, H, W = masks.shape
    if labels.shape[-2:] != (H, W):
        labels = F.interpolate(labels[:, None].float(), size=(H, W), mode="nearest")[:, 0]
    targets = instance_targets(labels.long(), n)
    total = masks.new_zeros(())
    for b in range(B):
        S = masks[b].reshape(n, H * W)
        T = targets[b].to(S.device)
        cost = pairwise_dice_bce(S, T)
        rows, cols = linear_sum_assignment(cost.detach().cpu().numpy())
        matched = cost[torch.as_tensor(rows), torch.as_tensor(cols)].mean()
        unmatched = torch.ones(n, dtype=torch.bool, device=S.device)
        unmatched[torch.as_tensor(rows, device=S.device)] = False
        empty = S[unmatched].mean() if unmatched.any() else S.new_zeros(())
        total = total + matched + empty
    return total / B
