"""All networks together (neuraltex/networks.py): shapes connect, gradients reach every
parameter, no NaN, presets. Per-module tests: test_encoder, test_segmentation, test_generator,
test_discriminators, test_backbones."""

from __future__ import annotations

import pytest
import torch

from neuraltex.backbones import ResNet50Backbone
from neuraltex.discriminators import random_crops
from neuraltex.encoder import EncoderConfig
from neuraltex.generator import GeneratorConfig
from neuraltex.networks import NetworksConfig, build_networks
from neuraltex.nn_utils import count_parameters, pad_to_multiple

pytestmark = pytest.mark.usefixtures("one_thread", "seeded")


def _assert_all_grads(module: torch.nn.Module) -> None:
    missing = [n for n, p in module.named_parameters() if p.grad is None or not p.grad.any()]
    assert not missing, f"parameters without gradient: {missing}"


def test_gradients_reach_every_parameter(tiny):
    nets = build_networks(tiny)
    # 64^2: at 32^2 the stride-32 memory is a single token, and softmax over one key gives its
    # cross-attention q/k projections (layers 0 and 3) no gradient; that is expected, not a bug.
    x = torch.rand(2, 3, 64, 64)
    f_a, v = nets.encoder(x)
    (f_a * torch.randn_like(f_a)).sum().add((v * torch.randn_like(v)).sum()).backward()
    # The anchor prior makes each query own ~1/16 of the image, so masked attention leaves it
    # one stride-32 token at 64^2; at 128^2 (16 tokens) every projection gets a gradient.
    out = nets.segmentation(torch.rand(2, 3, 128, 128))
    (out.logits * torch.randn_like(out.logits)).sum().backward()  # sum(S) would be constant
    c = tiny.generator.feature_channels
    img = nets.generator(torch.rand(2, c, 32, 32), torch.rand(2, 1, 32, 32))
    (img * torch.randn_like(img)).sum().backward()
    nets.discriminator(x).sum().backward()
    crops = random_crops(x, tiny.patch_discriminator.crop_size)
    nets.patch_discriminator(crops, crops.flip(0)).mean().backward()
    for name, module in nets.named_children():
        assert count_parameters(module) > 0, name
        _assert_all_grads(module)


def _stand_in_splat(masks, f_a, v):
    """Stand-in for estimation + splatting when textons do not overlap: pool per mask
    (eqs. 4.6-4.7), paint back with the masks, F_max = max_i S_i. Only for shape/grad tests."""
    w = masks / masks.sum(dim=(2, 3), keepdim=True).clamp_min(1e-6)  # (B, n, H, W)
    feats = torch.cat((f_a, v), dim=1)  # (B, C_a+2, H, W)
    per_texton = torch.einsum("bnhw,bchw->bnc", w, feats)  # (B, n, C_a+2)
    per_texton = torch.nn.functional.normalize(per_texton, dim=-1)
    f_s = torch.einsum("bnhw,bnc->bchw", masks, per_texton)  # (B, C_a+2, H, W)
    return f_s, masks.amax(dim=1, keepdim=True)  # F_s, F_max (B, 1, H, W)


def test_shapes_connect_and_gradients_reach_encoders_through_generator(tiny):
    nets = build_networks(tiny)
    x = torch.rand(2, 3, 48, 48)
    f_a, v = nets.encoder(x)
    masks = nets.segmentation(x).masks
    f_s, f_max = _stand_in_splat(masks, f_a, v)
    img = nets.generator(f_s, f_max)
    assert img.shape == x.shape
    (img - x).abs().mean().backward()
    for module in (nets.encoder, nets.segmentation, nets.generator):
        assert all(p.grad is not None for p in module.parameters())
        assert sum(p.grad.abs().sum() for p in module.parameters()) > 0


def test_eval_mode_batch_one_any_size(tiny):
    nets = build_networks(tiny).eval()
    x = torch.rand(1, 3, 45, 29)
    with torch.no_grad():
        f_a, v = nets.encoder(x)
        out = nets.segmentation(x)
        img = nets.generator(torch.rand(1, tiny.generator.feature_channels, 45, 29),
                             torch.rand(1, 1, 45, 29))
        score = nets.discriminator(x)
    assert f_a.shape[-2:] == v.shape[-2:] == out.masks.shape[-2:] == img.shape[-2:] == (45, 29)
    assert score.shape == (1, 1)


def test_constant_image_no_nan(tiny):
    nets = build_networks(tiny)
    for value in (0.0, 0.5, 1.0):
        x = torch.full((2, 3, 32, 32), value, requires_grad=True)
        f_a, v = nets.encoder(x)
        out = nets.segmentation(x)
        c = tiny.generator.feature_channels
        img = nets.generator(torch.full((2, c, 32, 32), value), torch.full((2, 1, 32, 32), value))
        loss = f_a.mean() + v.mean() + (out.masks * out.masks.log()).mean() + img.mean()
        loss = loss + nets.discriminator(x).mean()
        loss.backward()
        for t in (f_a, v, out.logits, out.masks, img, x.grad):
            assert torch.isfinite(t).all()
        for p in nets.parameters():
            assert p.grad is None or torch.isfinite(p.grad).all()


def test_presets_are_consistent_and_tiny_is_small():
    for name in ("tiny", "small"):
        cfg = NetworksConfig.preset(name)
        assert cfg.generator.feature_channels == cfg.encoder.appearance_channels + 2
    counts = build_networks("tiny").parameter_counts()
    assert 0.3e6 < counts["total"] < 1.5e6
    with pytest.raises(ValueError):
        NetworksConfig(encoder=EncoderConfig(appearance_channels=10),
                       generator=GeneratorConfig(feature_channels=10))
    with pytest.raises(ValueError):
        NetworksConfig.preset("huge")


def test_paper_preset_key_sizes_without_forward():
    cfg = NetworksConfig.preset("paper")
    assert cfg.segmentation.num_queries == 100 and cfg.segmentation.num_layers == 4
    assert cfg.encoder.appearance_channels == 382 and cfg.generator.feature_channels == 384
    nets = build_networks(cfg)
    seg = nets.segmentation
    assert isinstance(seg.backbone, ResNet50Backbone)
    assert seg.query_feat.shape[0] == 100 and len(seg.layers) == 4
    assert len(nets.generator.blocks) == 4  # 4 SPADE res-blocks: H/4x384, H/2x192, Hx96, Hx3
    assert [b.conv_1.out_channels for b in nets.generator.blocks] == [384, 192, 96, 3]
    assert nets.encoder.appearance[-1].block[-1][-1].out_channels == 382
    assert nets.generator.blocks[0].norm_0.shared[0].in_channels == 384  # F_s = 382 + 2
    counts = nets.parameter_counts()
    assert 60e6 < counts["total"] < 120e6, counts
    assert 25e6 < counts["segmentation"] < 45e6, counts  # ResNet-50 alone is 23.5M


def test_pad_to_multiple():
    assert pad_to_multiple(torch.rand(1, 1, 37, 50), 32).shape[-2:] == (64, 64)
    assert pad_to_multiple(torch.rand(1, 1, 5, 5), 32).shape[-2:] == (32, 32)  # replicate
