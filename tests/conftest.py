"""Shared fixtures: random but valid texton sets."""

from __future__ import annotations

import pytest
import torch
import torch.nn.functional as F

from neuraltex.textons import Textons

SIZES = [(32, 32), (48, 64)]  # network tests: one square, one non-square input
BATCHES = [1, 2]


def make_textons(B: int = 2, K: int = 5, C: int = 4, *, dtype=torch.float32, seed: int = 0,
                 scale: float = 0.15) -> Textons:
    g = torch.Generator().manual_seed(seed)
    A = torch.randn(B, K, 2, 2, generator=g, dtype=dtype) * scale
    cov = A @ A.transpose(-1, -2) + 0.002 * torch.eye(2, dtype=dtype)
    order = torch.stack([torch.randperm(K, generator=g) for _ in range(B)])
    return Textons(
        mu=torch.rand(B, K, 2, generator=g, dtype=dtype),
        cov=cov,
        v=F.normalize(torch.randn(B, K, 2, generator=g, dtype=dtype), dim=-1),
        f=torch.randn(B, K, C, generator=g, dtype=dtype),
        p=torch.rand(B, K, generator=g, dtype=dtype),
        delta=torch.rand(B, K, generator=g, dtype=dtype),
        order=order,
    )


def single(mu, cov, f=(1.0,), delta=1.0, v=(1.0, 0.0), order=0) -> Textons:
    """One texton set holding one Gaussian (float64)."""
    t = lambda x: torch.tensor(x, dtype=torch.float64)  # noqa: E731
    return Textons(mu=t([[mu]]), cov=t([[cov]]), v=t([[v]]), f=t([[f]]), p=t([[delta]]),
                   delta=t([[delta]]), order=torch.tensor([[order]]))


def pytest_collection_modifyitems(config, items):
    """GPU-only tests are skipped, never failed, on machines without CUDA."""
    if torch.cuda.is_available():
        return
    skip = pytest.mark.skip(reason="needs CUDA")
    for item in items:
        if "gpu" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def textons() -> Textons:
    return make_textons()


@pytest.fixture(scope="session")
def tiny_checkpoint(tmp_path_factory) -> str:
    """An untrained tiny model export, for plumbing tests of the model commands. Its mask head
    is scaled up so the masks are nearly hard and some textons exist (p > 0.5, eq. 4.5)."""
    from neuraltex.checkpoint import export_model
    from neuraltex.model import build_model
    from neuraltex.model_config import ModelConfig

    config = ModelConfig(preset="tiny", image_size=32)
    torch.manual_seed(0)
    model = build_model(config)
    with torch.no_grad():
        last = model.segmenter.mask_head.embed[-1]
        last.weight.mul_(100)
        last.bias.mul_(100)
    path = tmp_path_factory.mktemp("model") / "tiny.safetensors"
    export_model(path, model.state_dict(), config, {"steps": 0})
    return str(path)


@pytest.fixture(scope="module")
def one_thread():
    """One torch thread for a module of tiny-network tests: tiny convs gain nothing from two
    OpenMP threads, and on a shared, loaded 2-core machine thread synchronisation made single
    tests swing from 0.5 s to 15 s."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture
def seeded():
    torch.manual_seed(0)


@pytest.fixture(scope="module")
def tiny():
    """The tiny preset's network sizes (neuraltex.networks.NetworksConfig)."""
    from neuraltex.networks import NetworksConfig

    return NetworksConfig.preset("tiny")
