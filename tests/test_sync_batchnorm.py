"""CrossRankBatchNorm2d: two gloo ranks of half a batch each compute what one BatchNorm2d
computes on the whole batch (outputs, every gradient, running statistics)."""

from __future__ import annotations

import copy

import torch
import torch.distributed as dist
import torch.multiprocessing as mp
from torch import nn

from train.sync_batchnorm import CrossRankBatchNorm2d, cross_rank_batchnorm


def _reference(affine: bool, momentum):
    torch.manual_seed(0)
    x = torch.randn(4, 3, 5, 6) * 3 + 1
    w = torch.randn(4, 3, 5, 6)  # the loss sum(w * y): a gradient that differs per pixel
    net = nn.Sequential(nn.Conv2d(3, 3, 1), nn.BatchNorm2d(3, affine=affine, momentum=momentum))
    return x, w, net


def _rank(rank: int, world: int, tmp: str, affine: bool, momentum) -> None:
    """One rank: its half of the batch through two training forwards, the loss's backward,
    then a no-grad training forward on rank 1 alone; saves what it computed to tmp."""
    dist.init_process_group("gloo", init_method=f"file://{tmp}/store", rank=rank,
                            world_size=world)
    torch.set_num_threads(1)
    x, w, net = _reference(affine, momentum)
    cross_rank_batchnorm(net)
    assert isinstance(net[1], CrossRankBatchNorm2d)
    part = slice(2 * rank, 2 * rank + 2)
    xr = x[part].clone().requires_grad_(True)
    for _ in range(2):
        y = net(xr)
    (w[part] * y).sum().backward()
    state = {k: v.clone() for k, v in net.state_dict().items()}
    copied = copy.deepcopy(net)  # as the export's recalibration does: the group is shared
    assert copied[1].shared.group is net[1].shared.group
    with torch.no_grad():  # plain BatchNorm without gradients: rank 1 alone must not hang
        if rank == 1:
            net(xr)
    grads = {k: p.grad.clone() for k, p in net.named_parameters()}
    for g in grads.values():  # the global loss is the sum of the ranks' losses
        dist.all_reduce(g)
    tracked = int(net[1].num_batches_tracked)
    torch.save((y.detach(), xr.grad, grads, state, tracked), f"{tmp}/rank{rank}.pt")
    dist.destroy_process_group()


def _check(tmp_path, affine: bool, momentum):
    ctx = mp.get_context("fork")
    procs = [ctx.Process(target=_rank, args=(r, 2, str(tmp_path), affine, momentum))
             for r in range(2)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(timeout=120)
        assert p.exitcode == 0
    x, w, net = _reference(affine, momentum)
    x = x.clone().requires_grad_(True)
    for _ in range(2):
        y = net(x)
    (w * y).sum().backward()
    for rank in range(2):
        yr, gx, grads, state, tracked = torch.load(tmp_path / f"rank{rank}.pt")
        part = slice(2 * rank, 2 * rank + 2)
        torch.testing.assert_close(yr, y.detach()[part], atol=1e-5, rtol=1e-5)
        torch.testing.assert_close(gx, x.grad[part], atol=1e-5, rtol=1e-5)
        for k, p in net.named_parameters():
            torch.testing.assert_close(grads[k], p.grad, atol=1e-4, rtol=1e-5)
        for k, v in net.state_dict().items():
            torch.testing.assert_close(state[k], v, atol=1e-5, rtol=1e-5)
        assert tracked == 2 + rank  # rank 1's no-grad forward: one local update


def test_two_ranks_equal_one_batchnorm_over_the_whole_batch(tmp_path):
    _check(tmp_path, affine=True, momentum=0.1)


def test_parameter_free_and_cumulative_batchnorm(tmp_path):
    _check(tmp_path, affine=False, momentum=None)  # SPADE's norm; the export's averaging


def test_a_plain_process_is_plain_batchnorm():
    x, w, net = _reference(True, 0.1)
    y_ref = net(x)
    net2 = _reference(True, 0.1)[2]
    net2[1] = CrossRankBatchNorm2d(3)  # no group: never synchronizes
    net2[1].load_state_dict(_reference(True, 0.1)[2][1].state_dict())
    torch.testing.assert_close(net2(x), y_ref)
