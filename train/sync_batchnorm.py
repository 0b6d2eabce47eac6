"""BatchNorm whose batch statistics span every data-parallel rank, on the CPU too.

Under ``torchrun --nproc_per_node=K`` each rank holds batch / K images. Plain BatchNorm then
normalizes each rank's slice by that slice's own mean and variance: noisier statistics and a
different function from the one-process step of the same global batch. torch's
``nn.SyncBatchNorm`` fixes that on GPUs only (it refuses CPU tensors), so the CPU runs here
use :class:`CrossRankBatchNorm2d`: the same forward and backward as one BatchNorm over the
global batch, with two small all-reduces per layer (sums and sums of squares forward; the
two gradient sums backward) on a process group of its own, apart from DDP's gradient buckets.

Only training-mode forwards with gradients enabled synchronize; anything else (evaluation,
the export's BatchNorm recalibration on rank 0 alone, no-grad passes) is plain BatchNorm, so
no rank can wait on a collective the others never call. State dicts are BatchNorm2d's.
"""

from __future__ import annotations

import torch
import torch.distributed as dist
from torch import nn


class _GlobalBatchNorm(torch.autograd.Function):
    """One BatchNorm over the batch of every rank of ``group``. x: (N, C, H, W) -> y (x's
    dtype), and, without gradients, the batch mean (C,) and biased variance (C,) over every
    rank's N x H x W and that count (a 0-d tensor), for the running statistics."""

    @staticmethod
    def forward(ctx, x, weight, bias, eps: float, group):
        xf, c = x.float(), x.shape[1]
        sums = torch.cat([xf.sum((0, 2, 3), dtype=torch.float64),
                          xf.square().sum((0, 2, 3), dtype=torch.float64),
                          torch.tensor([xf.numel() // c], dtype=torch.float64)])
        dist.all_reduce(sums, group=group)
        count = sums[-1]
        mean64 = sums[:c] / count
        var = (sums[c:2 * c] / count - mean64.square()).clamp_min(0).float()
        mean = mean64.float()
        invstd = (var + eps).rsqrt()
        xhat = (xf - mean[:, None, None]) * invstd[:, None, None]
        y = xhat if weight is None else xhat * weight.float()[:, None, None]
        y = y if bias is None else y + bias.float()[:, None, None]
        ctx.save_for_backward(xhat, invstd, weight)
        ctx.count, ctx.group, ctx.dtype = count, group, x.dtype
        ctx.mark_non_differentiable(mean, var, count)
        return y.to(x.dtype), mean, var, count

    @staticmethod
    def backward(ctx, gy, *_):
        xhat, invstd, weight = ctx.saved_tensors
        gy = gy.float()
        g = gy if weight is None else gy * weight.float()[:, None, None]
        c = g.shape[1]
        sums = torch.cat([g.sum((0, 2, 3), dtype=torch.float64),
                          (g * xhat).sum((0, 2, 3), dtype=torch.float64)])
        dist.all_reduce(sums, group=ctx.group)  # every rank's loss depends on every rank's x
        mean_g, mean_gx = (sums[:c] / ctx.count).float(), (sums[c:] / ctx.count).float()
        dx = (g - mean_g[:, None, None] - xhat * mean_gx[:, None, None]) * invstd[:, None, None]
        dw = (gy * xhat).sum((0, 2, 3)).to(weight.dtype) if ctx.needs_input_grad[1] else None
        db = gy.sum((0, 2, 3)).to(gy.dtype) if ctx.needs_input_grad[2] else None
        return dx.to(ctx.dtype), dw, db, None, None


@torch.compiler.disable  # collectives are not traced: a compiled part breaks its graph here
def _global_batch_norm(x, weight, bias, eps: float, group):
    return _GlobalBatchNorm.apply(x, weight, bias, eps, group)


class _Shared:
    """A process group held by reference: a deep copy of the model (the export's BatchNorm
    recalibration makes one) shares it instead of trying to pickle it."""

    def __init__(self, group) -> None:
        self.group = group

    def __deepcopy__(self, memo) -> _Shared:
        return self


class CrossRankBatchNorm2d(nn.BatchNorm2d):
    """nn.BatchNorm2d whose training statistics cover the batch of every rank of ``group``
    (plain BatchNorm2d while ``group`` is None, in evaluation, or without gradients)."""

    def __init__(self, *args, group=None, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.shared = _Shared(group)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        group = self.shared.group
        if not (self.training and torch.is_grad_enabled() and group is not None):
            return super().forward(x)
        self._check_input_dim(x)
        y, mean, var, count = _global_batch_norm(x, self.weight, self.bias, self.eps, group)
        if self.track_running_stats:  # as nn.BatchNorm2d: the unbiased variance is tracked
            self.num_batches_tracked.add_(1)
            m = 1.0 / float(self.num_batches_tracked) if self.momentum is None else self.momentum
            with torch.no_grad():
                self.running_mean.lerp_(mean.to(self.running_mean.dtype), m)
                unbiased = var * (count / (count - 1).clamp_min(1))
                self.running_var.lerp_(unbiased.to(self.running_var.dtype), m)
        return y


def cross_rank_batchnorm(module: nn.Module, group=None) -> nn.Module:
    """``module`` with every nn.BatchNorm2d replaced by a :class:`CrossRankBatchNorm2d` that
    shares its parameters and buffers and synchronizes over ``group`` (default: a new gloo
    group of all ranks, which is a collective call: every rank must make it)."""
    group = group if group is not None else dist.new_group(backend="gloo")
    for name, child in list(module.named_children()):
        if type(child) is nn.BatchNorm2d:
            new = CrossRankBatchNorm2d(child.num_features, child.eps, child.momentum,
                                       child.affine, child.track_running_stats, group=group)
            new.weight, new.bias = child.weight, child.bias
            new.running_mean, new.running_var = child.running_mean, child.running_var
            new.num_batches_tracked = child.num_batches_tracked
            new.train(child.training)
            setattr(module, name, new)
        else:
            cross_rank_batchnorm(child, group)
    return module
