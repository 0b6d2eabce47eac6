"""D and D_p (neuraltex/discriminators.py): shapes, crops, R1 double backward, presets."""

from __future__ import annotations

import pytest
import torch

from conftest import BATCHES, SIZES
from neuraltex.discriminators import (
    DiscriminatorConfig,
    ImageDiscriminator,
    PatchDiscriminator,
    PatchDiscriminatorConfig,
    random_crops,
)

pytestmark = pytest.mark.usefixtures("one_thread", "seeded")


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES + [(16, 16), (24, 40)])
def test_image_discriminator_shapes(tiny, b, hw):
    d = ImageDiscriminator.from_config(tiny.discriminator)
    assert d(torch.rand(b, 3, *hw)).shape == (b, 1)


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES)
def test_patch_discriminator_with_crops(tiny, b, hw):
    cfg = tiny.patch_discriminator
    dp = PatchDiscriminator.from_config(cfg)
    real, fake = torch.rand(b, 3, *hw), torch.rand(b, 3, *hw)
    ref = random_crops(real, cfg.crop_size, cfg.num_crops)
    crops = random_crops(fake, cfg.crop_size, cfg.num_crops)
    assert ref.shape == (b * 8, 3, cfg.crop_size, cfg.crop_size)
    logits = dp(ref, crops)
    assert logits.shape[:2] == (b * 8, 1) and logits.numel() > 0


def test_random_crops_content_and_determinism():
    x = torch.arange(2 * 3 * 10 * 12, dtype=torch.float32).view(2, 3, 10, 12)
    crops = random_crops(x, 4, num_crops=5, generator=torch.Generator().manual_seed(1))
    again = random_crops(x, 4, num_crops=5, generator=torch.Generator().manual_seed(1))
    assert torch.equal(crops, again)
    for i in range(10):  # every crop is a contiguous window of its own image
        b, c = divmod(i, 5)
        y0, x0 = divmod(int(crops[i, 0, 0, 0].item()) - b * 360, 12)
        assert torch.equal(crops[i], x[b, :, y0:y0 + 4, x0:x0 + 4])
    with pytest.raises(ValueError):
        random_crops(x, 11)


@pytest.mark.parametrize("which", ["image", "patch"])
def test_discriminators_support_r1_double_backward(tiny, which):
    """Lazy R1 (7.7.2) differentiates the input gradient's norm w.r.t. the weights."""
    if which == "image":
        d = ImageDiscriminator.from_config(tiny.discriminator)
        x = torch.rand(2, 3, 32, 32, requires_grad=True)
        score = d(x)
    else:
        d = PatchDiscriminator.from_config(tiny.patch_discriminator)
        ref = torch.rand(8, 3, 16, 16)
        x = torch.rand(8, 3, 16, 16, requires_grad=True)
        score = d(ref, x)
    (grad,) = torch.autograd.grad(score.sum(), x, create_graph=True)
    grad.pow(2).flatten(1).sum(1).mean().backward()
    # the input gradient does not depend on biases (leaky ReLU is piecewise linear): weights only
    weights = [p for p in d.parameters() if p.dim() > 1]
    assert all(p.grad is not None and p.grad.any() and torch.isfinite(p.grad).all()
               for p in weights)


@pytest.mark.parametrize("name", ["tiny", "small"])
def test_image_discriminator_presets_score_any_image_size(name):
    d = ImageDiscriminator.from_config(DiscriminatorConfig.preset(name))
    for hw in ((16, 16), (40, 24)):
        score = d(torch.rand(2, 3, *hw))
        assert score.shape == (2, 1) and torch.isfinite(score).all()


@pytest.mark.parametrize("name", ["tiny", "small", "paper"])
def test_patch_discriminator_presets_judge_their_own_crops(name):
    """Each preset's D_p gives a non-empty logit map for num_crops crops of its crop_size."""
    dp = PatchDiscriminator.from_config(PatchDiscriminatorConfig.preset(name))
    crops = random_crops(torch.rand(2, 3, 64, 64), dp.crop_size, dp.num_crops)
    logits = dp(crops, crops.flip(0))
    assert logits.shape[:2] == (2 * dp.num_crops, 1) and logits.numel() > 2 * dp.num_crops - 1


def test_patch_discriminator_rejects_mismatched_crops():
    with pytest.raises(ValueError):
        PatchDiscriminator()(torch.rand(1, 3, 16, 16), torch.rand(1, 3, 32, 32))
