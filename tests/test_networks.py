"""Network modules: shapes, masking, resolution independence, gradients, presets (CPU, fast)."""

from __future__ import annotations

import pytest
import torch
import torchvision

from neuraltex.backbones import ResNet50Backbone
from neuraltex.discriminators import (
    DiscriminatorConfig,
    ImageDiscriminator,
    PatchDiscriminator,
    PatchDiscriminatorConfig,
    random_crops,
)
from neuraltex.encoder import EncoderConfig, FCEncoder
from neuraltex.generator import GeneratorConfig, SPADEGenerator, level_sizes
from neuraltex.networks import NetworksConfig, build_networks
from neuraltex.nn_utils import count_parameters, pad_to_multiple
from neuraltex.segmentation import (
    SegmentationConfig,
    SegmentationNet,
    masked_attention,
    sine_position_encoding,
)

SIZES = [(32, 32), (48, 64)]
BATCHES = [1, 2]


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    # Tiny convs gain nothing from 2 OpenMP threads, and on a shared, loaded 2-core machine
    # thread synchronisation made single tests swing from 0.5 s to 15 s.
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)


@pytest.fixture(scope="module")
def tiny():
    torch.manual_seed(0)
    return NetworksConfig.preset("tiny")


def _assert_all_grads(module: torch.nn.Module) -> None:
    missing = [n for n, p in module.named_parameters() if p.grad is None or not p.grad.any()]
    assert not missing, f"parameters without gradient: {missing}"


# ----------------------------------------------------------------------------- shapes


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES)
def test_encoder_shapes(tiny, b, hw):
    enc = FCEncoder.from_config(tiny.encoder)
    f_a, v = enc(torch.rand(b, 3, *hw))
    assert f_a.shape == (b, tiny.encoder.appearance_channels, *hw)
    assert v.shape == (b, 2, *hw)


def test_encoder_native_stride_and_odd_size(tiny):
    enc = FCEncoder.from_config(tiny.encoder)
    f_a, v = enc(torch.rand(2, 3, 37, 50))
    assert f_a.shape[-2:] == v.shape[-2:] == (37, 50)
    enc.upsample_output = False
    f_a, v = enc(torch.rand(2, 3, 64, 48))
    assert enc.stride == 4 and f_a.shape[-2:] == (16, 12)


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES)
def test_segmentation_shapes_and_softmax(tiny, b, hw):
    seg = SegmentationNet.from_config(tiny.segmentation)
    out = seg(torch.rand(b, 3, *hw))
    n = tiny.segmentation.num_queries
    assert out.logits.shape == out.masks.shape == (b, n, *hw)
    assert len(out.aux_logits) == tiny.segmentation.num_layers + 1
    assert torch.allclose(out.masks.sum(dim=1), torch.ones(b, *hw), atol=1e-5)
    assert (out.masks >= 0).all()


def test_segmentation_odd_size(tiny):
    seg = SegmentationNet.from_config(tiny.segmentation)
    out = seg(torch.rand(1, 3, 37, 50))
    assert out.masks.shape == (1, tiny.segmentation.num_queries, 37, 50)


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES)
def test_generator_shapes_and_range(tiny, b, hw):
    gen = SPADEGenerator.from_config(tiny.generator)
    img = gen(torch.rand(b, tiny.generator.feature_channels, *hw), torch.rand(b, 1, *hw))
    assert img.shape == (b, 3, *hw)
    assert img.min() >= -1 and img.max() <= 1


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


# ----------------------------------------------------------------------------- behaviour


def test_masked_attention_function_zeroes_blocked():
    q, k, v = torch.randn(2, 4, 3, 8), torch.randn(2, 4, 10, 8), torch.randn(2, 4, 10, 8)
    blocked = torch.zeros(2, 3, 10, dtype=torch.bool)
    blocked[:, 0, 5:] = True  # query 0 may only look at the first half
    out, w = masked_attention(q, k, v, blocked)
    assert (w[:, :, 0, 5:] == 0).all()
    assert torch.allclose(w.sum(-1), torch.ones(2, 4, 3))
    ref, _ = masked_attention(q[:, :, :1], k[:, :, :5], v[:, :, :5])  # same as dropping keys
    assert torch.allclose(out[:, :, :1], ref, atol=1e-6)


def test_masked_attention_gradcheck_float64():
    q, k, v = (torch.randn(1, 2, 3, 4, dtype=torch.float64, requires_grad=True) for _ in range(3))
    blocked = torch.tensor([[[False, True, False], [False, False, False], [True, True, False]]])
    assert torch.autograd.gradcheck(lambda a, b, c: masked_attention(a, b, c, blocked)[0],
                                    (q, k, v))


@pytest.mark.parametrize("mode", ["softmax", "sigmoid"])
def test_decoder_attention_is_masked_by_previous_prediction(tiny, mode):
    cfg = SegmentationConfig(**{**tiny.segmentation.__dict__, "attn_mask_mode": mode})
    seg = SegmentationNet.from_config(cfg)
    out = seg(torch.rand(2, 3, 64, 64), return_attention=True)
    assert len(out.attn_masks) == len(out.attn_weights) == cfg.num_layers
    for blocked, w, prev in zip(out.attn_masks, out.attn_weights,
                                out.aux_logits[:-1], strict=True):
        assert w.shape[-1] == blocked.shape[-1]
        assert (w.permute(1, 0, 2, 3)[:, blocked] == 0).all()  # zero weight where blocked
        side = round(blocked.shape[-1] ** 0.5)  # square input: square memory levels
        # the mask comes from the previous layer's prediction (the initial queries' for layer 0)
        assert torch.equal(blocked, seg.blocked_from_logits(prev, (side, side)))
    assert any(b.any() for b in out.attn_masks), "masks never block anything"


def test_generator_resolution_independent(tiny):
    gen = SPADEGenerator.from_config(tiny.generator)
    c = tiny.generator.feature_channels
    gen(torch.rand(2, c, 32, 32), torch.rand(2, 1, 32, 32))  # "training" resolution
    gen.eval()
    for hw in [(64, 64), (40, 56), (17, 23)]:
        img = gen(torch.rand(1, c, *hw), torch.rand(1, 1, *hw))
        assert img.shape == (1, 3, *hw) and torch.isfinite(img).all()
    assert level_sizes((17, 23), 3) == [(5, 6), (9, 12), (17, 23)]


@pytest.mark.parametrize("kw", [{"spade_kernel": 1}, {"norm": "instance"},
                                {"use_spectral_norm": False, "output_activation": "sigmoid"}])
def test_generator_options(kw):
    gen = SPADEGenerator(feature_channels=6, channels=(8, 8, 8), spade_hidden=8, **kw)
    img = gen(torch.rand(2, 6, 24, 20), torch.rand(2, 1, 24, 20))
    assert img.shape == (2, 3, 24, 20)
    assert img.min() >= (0 if kw.get("output_activation") == "sigmoid" else -1)


def test_generator_uses_max_opacity_input():
    gen = SPADEGenerator(feature_channels=6, channels=(8, 8, 8), spade_hidden=8,
                         concat_features=False).eval()
    f = torch.rand(1, 6, 32, 32)
    a = gen(f, torch.zeros(1, 1, 32, 32))
    b = gen(f, torch.rand(1, 1, 32, 32))
    assert not torch.allclose(a, b)
    with pytest.raises(ValueError):
        gen(f, torch.rand(1, 1, 16, 16))


def test_sine_position_encoding_shape_and_range():
    pe = sine_position_encoding(5, 7, 10)
    assert pe.shape == (10, 5, 7) and pe.abs().max() <= 1
    assert not torch.allclose(pe[:, 0, 0], pe[:, 4, 6])


def test_pad_to_multiple():
    assert pad_to_multiple(torch.rand(1, 1, 37, 50), 32).shape[-2:] == (64, 64)
    assert pad_to_multiple(torch.rand(1, 1, 5, 5), 32).shape[-2:] == (32, 32)  # replicate


# ----------------------------------------------------------------------------- gradients, NaN


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


def test_bad_arguments_raise():
    with pytest.raises(ValueError):
        SegmentationNet(backbone="small", backbone_channels=(8, 16), num_queries=4)
    with pytest.raises(ValueError):
        SegmentationNet(backbone="small", hidden_dim=30, num_heads=4, num_queries=4)
    with pytest.raises(ValueError):
        FCEncoder(down_channels=(8,), up_channels=(8,))
    with pytest.raises(ValueError):
        PatchDiscriminator()(torch.rand(1, 3, 16, 16), torch.rand(1, 3, 32, 32))


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


# ----------------------------------------------------------------------------- presets


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


def test_resnet50_backbone_loads_local_weights_only(tmp_path):
    ref = torchvision.models.resnet50(weights=None)
    path = tmp_path / "r50.pt"
    torch.save(ref.state_dict(), path)
    bb = ResNet50Backbone(weights_path=str(path))
    assert torch.equal(bb.stages[3][0].conv1.weight, ref.layer4[0].conv1.weight)
    assert bb.out_channels == (256, 512, 1024, 2048)


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


def test_discriminator_config_presets():
    for name in ("tiny", "small", "paper"):
        assert DiscriminatorConfig.preset(name).channels
        assert PatchDiscriminatorConfig.preset(name).num_crops == 8


def test_anchor_prior_starts_as_a_grid_partition_and_follows_its_offsets():
    from neuraltex.segmentation import AnchorPrior

    prior = AnchorPrior(num_queries=9, hidden_dim=8)
    q = torch.zeros(1, 9, 8)
    owner = prior(q, (30, 30), (1.0, 1.0)).argmax(1)[0]  # (30, 30)
    expected = (torch.arange(30) // 10)[:, None] * 3 + (torch.arange(30) // 10)[None, :]
    assert torch.equal(owner, expected)  # 3 x 3 grid, raster order
    with torch.no_grad():
        prior.head.bias[:2] = torch.tensor([10.0, 0.0])  # tanh -> +2 cells in x for all
    shifted = prior(q, (30, 30), (1.0, 1.0))
    # query 0 (anchor at column 0) now peaks two cells to the right
    peak = shifted[0, 0].amax(0).argmax()
    assert 20 <= int(peak) <= 29
