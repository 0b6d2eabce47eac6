import pytest
import torch

from neuraltex.checkpoint import CheckpointError, export_model
from neuraltex.model import build_model, load_model
from neuraltex.model_config import ModelConfig

CONFIG = ModelConfig(preset="tiny", image_size=32)


@pytest.fixture(scope="module")
def model():
    torch.manual_seed(0)
    return build_model(CONFIG).eval()


@pytest.mark.parametrize("size, batch", [((32, 32), 1), ((48, 64), 2)])
def test_encode_decode_shapes_at_any_size(model, size, batch):
    image = torch.rand(batch, 3, *size)
    with torch.no_grad():
        enc = model.encode(image)
        out = model.decode(enc.textons, size)
        big = model.decode(enc.textons, (size[0] * 2, size[1] * 2))
    assert enc.masks.shape[:2] == (batch, enc.textons.num_textons)
    s = min(1.0, 32 / min(size))  # inputs above the training size are encoded at it
    hw = tuple(round(d * s) for d in size)
    assert torch.allclose(enc.masks.sum(1), torch.ones(batch, *hw), atol=1e-5)
    assert enc.textons.canvas == pytest.approx((size[1] / min(size), size[0] / min(size)))
    assert out.shape == (batch, 3, *size) and big.shape[-2:] == (size[0] * 2, size[1] * 2)
    assert 0 <= out.min() and out.max() <= 1


def test_gradients_reach_encoder_segmenter_and_generator():
    torch.manual_seed(1)
    model = build_model(CONFIG).train()
    image = torch.rand(2, 3, 32, 32)
    enc = model.encode(image, existence="sample")
    loss = (model.decode(enc.textons, (32, 32)) - image).abs().mean()
    loss.backward()
    for name in ("encoder", "segmenter", "generator"):
        grads = [p.grad for p in getattr(model, name).parameters() if p.requires_grad]
        assert any(g is not None and g.abs().sum() > 0 for g in grads), name


def test_constant_image_gives_finite_output(model):
    with torch.no_grad():
        out = model.reconstruct(torch.full((1, 3, 32, 32), 0.5))
    assert torch.isfinite(out).all()


def test_export_load_round_trip_and_tamper(tmp_path, model):
    path = tmp_path / "m.safetensors"
    export_model(path, model.state_dict(), CONFIG, {"steps": 0})
    loaded = load_model(path)
    image = torch.rand(1, 3, 32, 32)
    with torch.no_grad():
        assert torch.allclose(loaded.reconstruct(image), model.reconstruct(image), atol=1e-6)
    state = dict(model.state_dict())
    state.pop(next(iter(state)))
    export_model(path, state, CONFIG, {})  # self-consistent file, but weights missing
    with pytest.raises(CheckpointError, match="do not fit"):
        load_model(path)


def test_encode_runs_at_the_native_resolution(model):
    import torch.nn.functional as F

    image = torch.rand(1, 3, 64, 96)
    small = F.interpolate(image, size=(32, 48), mode="bilinear", align_corners=False,
                          antialias=True)
    with torch.no_grad():
        big, ref = model.encode(image).textons, model.encode(small).textons
        full = model.encode(image, native=False)
    assert torch.allclose(big.mu, ref.mu, atol=1e-5) and torch.allclose(big.f, ref.f, atol=1e-5)
    assert big.canvas == ref.canvas == pytest.approx((1.5, 1.0))
    assert full.masks.shape[-2:] == (64, 96)  # the trainer's path keeps the input size
