"""E_s (neuraltex/segmentation.py): shapes, softmax masks, masked attention, anchor prior."""

from __future__ import annotations

import pytest
import torch

from conftest import BATCHES, SIZES
from neuraltex.segmentation import (
    SMALL_KEYS,
    SegmentationConfig,
    SegmentationNet,
    masked_attention,
    sine_position_encoding,
)
from neuraltex.small_attention import small_attention

pytestmark = pytest.mark.usefixtures("one_thread", "seeded")


@pytest.mark.parametrize("b", BATCHES)
@pytest.mark.parametrize("hw", SIZES)
def test_segmentation_shapes_and_softmax(tiny, b, hw):
    seg = SegmentationNet.from_config(tiny.segmentation)
    out = seg(torch.rand(b, 3, *hw), aux=True)
    n = tiny.segmentation.num_queries
    assert out.logits.shape == out.masks.shape == (b, n, *hw)
    assert len(out.aux_logits) == tiny.segmentation.num_layers + 1
    assert torch.allclose(out.masks.sum(dim=1), torch.ones(b, *hw), atol=1e-5)
    assert (out.masks >= 0).all()


def test_segmentation_odd_size(tiny):
    seg = SegmentationNet.from_config(tiny.segmentation)
    out = seg(torch.rand(1, 3, 37, 50))
    assert out.masks.shape == (1, tiny.segmentation.num_queries, 37, 50)


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


@pytest.mark.parametrize("per_head", [False, True])
@pytest.mark.parametrize("keys", [9, SMALL_KEYS + 1])  # small_attention, torch's fused kernel
def test_attention_without_weights_equals_the_explicit_one(per_head, keys):
    """need_weights=False (training: small_attention's closed-form backward for few keys,
    else torch's fused kernel) gives the explicit softmax's output and gradients, with
    blocked keys, in float64."""
    q, k, v = (torch.randn(2, 4, 7 if i == 0 else keys, 8, dtype=torch.float64,
                           requires_grad=True) for i in range(3))
    blocked = torch.rand(2, 4, 7, keys) < 0.6 if per_head else torch.rand(2, 7, keys) < 0.6
    blocked[..., 0] = False  # every query has a key
    fast, none = masked_attention(q, k, v, blocked, need_weights=False)
    ref, w = masked_attention(q, k, v, blocked)
    assert none is None and w is not None and torch.allclose(fast, ref, atol=1e-12)
    g = torch.randn_like(ref)
    assert all(torch.allclose(a, b, atol=1e-12) for a, b in zip(
        torch.autograd.grad(fast, (q, k, v), g), torch.autograd.grad(ref, (q, k, v), g),
        strict=True))
    unmasked, _ = masked_attention(q, k, v, torch.zeros_like(blocked), need_weights=False)
    assert not torch.allclose(unmasked, ref, atol=1e-3)  # the mask is applied


def test_small_attention_gradcheck_on_strided_heads():
    """Closed-form backward against finite differences, float64, with q/k/v laid out as the
    Attention module splits them (heads as a transposed view) and a mask shared by heads."""
    q, k, v = (torch.randn(2, n, 3, 4, dtype=torch.float64).transpose(1, 2).requires_grad_()
               for n in (5, 6, 6))
    blocked = torch.rand(2, 1, 5, 6) < 0.5
    blocked[..., 2] = False
    assert torch.autograd.gradcheck(lambda a, b, c: small_attention(a, b, c, blocked),
                                    (q, k, v))
    out = small_attention(q, k, v, blocked)
    w = torch.softmax((q @ k.transpose(-2, -1) / 2).masked_fill(blocked, float("-inf")), -1)
    assert torch.allclose(out, w @ v, atol=1e-12)


def test_small_attention_under_bfloat16_autocast_gives_float32_gradients():
    q, k, v = (torch.randn(2, 4, n, 8, requires_grad=True) for n in (10, 16, 16))
    with torch.autocast("cpu", dtype=torch.bfloat16):
        out = small_attention(q, k, v, torch.rand(2, 1, 10, 16) < 0.3)
    out.float().sum().backward()
    assert out.dtype == torch.bfloat16
    assert all(t.grad.dtype == torch.float32 and torch.isfinite(t.grad).all() for t in (q, k, v))


def test_segmenter_logits_equal_with_and_without_attention_weights(tiny):
    seg = SegmentationNet.from_config(tiny.segmentation).double()
    x = torch.rand(2, 3, 64, 64, dtype=torch.float64)
    plain, traced = seg(x).logits, seg(x, return_attention=True).logits
    assert torch.allclose(plain, traced, atol=1e-10)


@pytest.mark.parametrize("mode", ["softmax", "sigmoid"])
def test_decoder_attention_is_masked_by_previous_prediction(tiny, mode):
    cfg = SegmentationConfig(**{**tiny.segmentation.__dict__, "attn_mask_mode": mode})
    seg = SegmentationNet.from_config(cfg)
    out = seg(torch.rand(2, 3, 64, 64), return_attention=True, aux=True)
    assert len(out.attn_masks) == len(out.attn_weights) == cfg.num_layers
    for blocked, w, prev in zip(out.attn_masks, out.attn_weights,
                                out.aux_logits[:-1], strict=True):
        assert w.shape[-1] == blocked.shape[-1]
        assert (w.permute(1, 0, 2, 3)[:, blocked] == 0).all()  # zero weight where blocked
        side = round(blocked.shape[-1] ** 0.5)  # square input: square memory levels
        # the mask comes from the previous layer's prediction (the initial queries' for layer 0)
        assert torch.equal(blocked, seg.blocked_from_logits(prev, (side, side)))
    assert any(b.any() for b in out.attn_masks), "masks never block anything"


@pytest.mark.parametrize("mode", ["softmax", "sigmoid"])
@pytest.mark.parametrize("hw", [(64, 64), (128, 96), (37, 50)])
def test_attention_masks_from_level_size_predictions_equal_the_resampled_ones(tiny, mode, hw):
    """Without ``aux`` each layer's attention mask comes from a prediction made at its memory
    level's size (query . resampled features + the resampled separable prior): the same
    masks, hence the same logits, as resampling the full stride-4 predictions (float64)."""
    cfg = SegmentationConfig(**{**tiny.segmentation.__dict__, "attn_mask_mode": mode})
    seg = SegmentationNet.from_config(cfg).double()
    with torch.no_grad():  # a trained-like prior: offsets and spreads away from zero
        seg.anchor_prior.head.weight.normal_(0, 0.5)
    x = torch.rand(2, 3, *hw, dtype=torch.float64)
    fast, ref = seg(x, return_attention=True), seg(x, return_attention=True, aux=True)
    assert fast.aux_logits == [] and len(ref.aux_logits) == cfg.num_layers + 1
    assert all(torch.equal(a, b) for a, b in zip(fast.attn_masks, ref.attn_masks, strict=True))
    if mode == "softmax":  # (random sigmoid masks block everything, i.e. nothing)
        assert any(m.any() for m in fast.attn_masks)
    assert torch.allclose(fast.logits, ref.logits, atol=1e-12)
    coarse = seg._coarse_predictor  # the level-size prediction against resampling
    feats, _ = seg.pixel_decoder(seg.backbone(x[..., :64, :64]))
    from neuraltex.nn_utils import bilinear_sample
    q = torch.randn(2, cfg.num_queries, cfg.hidden_dim, dtype=torch.float64)
    full = seg.mask_head(q, feats) + seg.anchor_prior(q, tuple(feats.shape[-2:]), (1.0, 1.0))
    got = coarse(feats, [(4, 4), (2, 2)], (1.0, 1.0))(q, 0)
    assert torch.allclose(got, bilinear_sample(full, (4, 4)), atol=1e-12)


def test_sine_position_encoding_shape_and_range():
    pe = sine_position_encoding(5, 7, 10)
    assert pe.shape == (10, 5, 7) and pe.abs().max() <= 1
    assert not torch.allclose(pe[:, 0, 0], pe[:, 4, 6])


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


def test_segmentation_bad_arguments_raise():
    with pytest.raises(ValueError):
        SegmentationNet(backbone="small", backbone_channels=(8, 16), num_queries=4)
    with pytest.raises(ValueError):
        SegmentationNet(backbone="small", hidden_dim=30, num_heads=4, num_queries=4)
