"""The same results on CUDA as on the CPU (skipped, never failed, without a GPU)."""

import pytest
import torch

from conftest import make_textons
from neuraltex.model import build_model
from neuraltex.model_config import ModelConfig
from neuraltex.splatting import splat, splat_reference

pytestmark = pytest.mark.gpu


def test_splatting_on_cuda_matches_the_cpu_reference():
    t = make_textons(B=2, K=6, C=3)
    ref = splat_reference(t, (24, 32))
    out = splat(t.to(device="cuda"), (24, 32))
    assert torch.allclose(out.features.cpu(), ref.features, atol=1e-4)
    assert torch.allclose(out.max_opacity.cpu(), ref.max_opacity, atol=1e-4)


def test_model_reconstructs_alike_on_cuda_and_cpu():
    torch.manual_seed(0)
    model = build_model(ModelConfig(preset="tiny", image_size=32)).eval()
    x = torch.rand(1, 3, 32, 32)
    with torch.no_grad():
        cpu = model.reconstruct(x)
        gpu = model.cuda().reconstruct(x.cuda()).cpu()
    assert torch.allclose(cpu, gpu, atol=1e-3)
