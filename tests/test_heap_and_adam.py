"""Allocator and optimizer settings of the training step: freed large tensors reused from
the heap (neuraltex.heap), the fused Adam and its resumption from unfused checkpoints."""

from __future__ import annotations

import copy
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from torch import nn

from neuraltex.nn_utils import adam, load_adam_state

_FAULTS = """
import resource, sys, torch
from neuraltex.heap import keep_freed_memory
torch.set_num_threads(1)  # with two, the count of the kept run swung 3,600-7,400
if sys.argv[1] == "1":
    assert keep_freed_memory()
S = torch.rand(8, 100, 1024)  # 3.3 MB, the mask loss's (B, n, P)
def cost():
    return (torch.log(S.clamp_min(1e-6)) - torch.log((1 - S).clamp_min(1e-6))).sum()
cost(), cost()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(8):
    cost()
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_freed_large_tensors_are_reused_without_page_faults():
    """The mask loss's temporaries (five 3.3 MB tensors a call, 800 pages each): glibc's
    default maps most of them afresh on every call (measured: 34,000 page faults in 8 calls);
    kept in the heap they are reused (4,000, the heap growing once)."""
    def faults(keep: str) -> int:
        out = subprocess.run([sys.executable, "-c", _FAULTS, keep], capture_output=True,
                             text=True, check=True)
        return int(out.stdout.split()[-1])

    default, kept = faults("0"), faults("1")
    assert default > 8 * 2 * 800, default  # at least two fresh tensors a call
    assert kept < 8 * 800, (kept, default)  # less than one a call (measured: 3,600-4,100)


def test_training_optimizers_are_fused_and_stay_fused_after_an_unfused_resume(tmp_path):
    """build() makes fused Adams; a state saved by an unfused Adam (checkpoints before the
    change) loads into them without switching the kernel off, and the next steps equal the
    unfused optimizer's to float rounding."""
    torch.manual_seed(0)
    net_old, net_new = nn.Linear(6, 4), nn.Linear(6, 4)
    old = torch.optim.Adam(net_old.parameters(), lr=1e-2, betas=(0.5, 0.999))
    x = torch.randn(16, 6)
    for _ in range(3):
        old.zero_grad()
        net_old(x).square().mean().backward()
        old.step()
    net_new.load_state_dict(net_old.state_dict())
    new = adam(net_new.parameters(), lr=5.0, betas=(0.1, 0.1))  # hyperparameters from state
    load_adam_state(new, copy.deepcopy(old.state_dict()))  # as read from a file
    assert new.param_groups[0]["fused"] is True and new.param_groups[0]["lr"] == 1e-2
    for net, opt in ((net_old, old), (net_new, new)):
        for _ in range(2):
            opt.zero_grad()
            net(x).square().mean().backward()
            opt.step()
    for a, b in zip(net_old.parameters(), net_new.parameters(), strict=True):
        assert torch.allclose(a, b, atol=1e-6)
    assert not torch.equal(net_new.weight, torch.zeros_like(net_new.weight))


def test_build_gives_fused_adams(tmp_path):
    from hydra import compose, initialize_config_dir

    from train.setup import build

    root = Path(__file__).resolve().parents[1]
    with initialize_config_dir(config_dir=str(root / "configs"), version_base="1.3"):
        cfg = compose(config_name="train", overrides=[f"run_dir={tmp_path}", "debug=fast"])
    parts = build(cfg, torch.device("cpu"))
    assert all(g["fused"] for opt in (parts.opt_g, parts.opt_d) for g in opt.param_groups)


def test_adam_falls_back_where_the_fused_kernel_does_not_run():
    """Parameters on a device without the kernel in every supported torch (here a meta
    tensor) get the usual Adam; parameter groups are looked into."""
    fused = adam([nn.Parameter(torch.zeros(3))], lr=0.1)
    assert fused.param_groups[0]["fused"] is True
    meta = adam([{"params": [nn.Parameter(torch.zeros(3))]},
                 {"params": [nn.Parameter(torch.zeros(3, device="meta"))]}], lr=0.1)
    assert not any(g["fused"] for g in meta.param_groups)


def test_adam_keeps_parameters_given_as_an_iterator_inside_a_group():
    net = nn.Linear(3, 2)
    opt = adam([{"params": net.parameters(), "lr": 0.1}])
    assert len(opt.param_groups[0]["params"]) == 2 and opt.param_groups[0]["fused"] is True
