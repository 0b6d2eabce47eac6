"""Texton detail sprites (neuraltex.texton_detail) and the per-pixel top-k weights they are
blended with (neuraltex.splatting.top_weights)."""

import math

import pytest
import torch
import torch.nn.functional as F

from neuraltex.splatting import opacity_maps, top_weights
from neuraltex.texton_detail import (
    REACH,
    DetailSampler,
    attach,
    fit_sprites,
    frames,
    render_detail,
    split,
    sprite_side,
)
from neuraltex.textons import Textons

pytestmark = pytest.mark.usefixtures("one_thread")


def random_textons(K: int = 12, B: int = 1, seed: int = 0, canvas=(1.0, 1.0)) -> Textons:
    g = torch.Generator().manual_seed(seed)
    A = torch.randn(B, K, 2, 2, generator=g) * 0.06
    cov = A @ A.transpose(-1, -2) + 2e-3 * torch.eye(2)
    mu = torch.rand(B, K, 2, generator=g) * torch.tensor(canvas)
    v = F.normalize(torch.randn(B, K, 2, generator=g), dim=-1)
    return Textons(mu=mu, cov=cov, v=v, f=torch.randn(B, K, 4, generator=g), p=torch.ones(B, K),
                   delta=torch.ones(B, K), order=torch.randperm(K, generator=g)[None].repeat(B, 1),
                   canvas=canvas)


def test_top_weights_are_the_largest_composited_weights():
    t = random_textons(30, B=2, canvas=(1.5, 1.0))
    t.delta = torch.rand(2, 30, generator=torch.Generator().manual_seed(1))
    w, idx = top_weights(t, (40, 60), 3, cutoff=3.0)
    dense = opacity_maps(t, (40, 60), cutoff=3.0)  # (B, K, H, W), index order
    torch.testing.assert_close(w, dense.topk(3, dim=1).values)
    torch.testing.assert_close(torch.gather(dense, 1, idx), w)


def test_frames_span_the_gaussian_and_follow_its_axis_or_direction():
    t = random_textons()
    t.cov[0, 0] = torch.eye(2) * 1e-3                      # round: the sprite turns with v
    t.cov[0, 1] = torch.tensor([[4e-3, 0.0], [0.0, 1e-3]])  # elongated along x
    t.v[0, 1] = F.normalize(torch.tensor([-1.0, 3.0]), dim=0)  # v mostly across it
    A = frames(t)
    torch.testing.assert_close(A @ A.transpose(-1, -2), REACH ** 2 * t.cov, atol=1e-6, rtol=1e-4)
    first = F.normalize(A[..., 0], dim=-1)
    torch.testing.assert_close(first[0, 0], t.v[0, 0], atol=1e-5, rtol=0)
    torch.testing.assert_close(first[0, 1], torch.tensor([-1.0, 0.0]), atol=1e-5, rtol=0)


def test_sprite_layout_round_trips_and_rejects_odd_widths():
    t = random_textons()
    sprites = torch.randn(1, 12, 3, 5, 5)
    plain, back = split(attach(t, sprites), 4)
    assert torch.equal(back, sprites) and torch.equal(plain.f, t.f)
    assert split(t, 4)[1] is None
    assert sprite_side(3 * 16 * 16) == 16
    for bad in (3, 10, 3 * 16 * 16 + 1):  # 3 would be a 1x1 "sprite": the colour offsets
        with pytest.raises(ValueError):
            sprite_side(bad)


def test_least_squares_sprites_reproduce_a_detail_image():
    t = random_textons(16)
    sampler = DetailSampler(t, (48, 48), cutoff=3.0)
    truth = torch.randn(1, 16, 3, 8, 8, generator=torch.Generator().manual_seed(2)) * 0.1
    target = sampler.render(truth)
    fitted = sampler.fit(target, side=8, iters=80, ridge=1e-6)
    err = (sampler.render(fitted) - target).pow(2).mean()
    assert err < 1e-3 * target.pow(2).mean()
    # texels no pixel samples stay at zero (the ridge), so a moved texton brings no noise
    t.mu[0, 0] = torch.tensor([5.0, 5.0])  # off the canvas: no pixel sees texton 0
    off = DetailSampler(t, (48, 48), cutoff=3.0).fit(target, side=8)
    assert off[0, 0].abs().max() == 0 and off[0, 1:].abs().max() > 0


def test_sprites_fitted_on_several_layouts_explain_each_and_skip_unknown_pixels():
    """Two layouts of the same textons (the second one moved): one set of sprites explains
    both targets; a pixel of weight 0 (a place whose look is unknown) does not pull it."""
    t = random_textons(16, seed=5)
    moved = random_textons(16, seed=5)
    moved.mu[0] += torch.tensor([0.1, -0.05])
    a, b = DetailSampler(t, (48, 48), cutoff=3.0), DetailSampler(moved, (48, 48), cutoff=3.0)
    truth = torch.randn(1, 16, 3, 8, 8, generator=torch.Generator().manual_seed(6)) * 0.1
    ta, tb = a.render(truth), b.render(truth)
    corrupt = tb.clone()
    corrupt[..., :16, :] += 0.5                              # wrong where the weight is 0
    weight = torch.ones(48, 48)
    weight[:16] = 0
    fitted = fit_sprites([a, b], [ta, corrupt], [None, weight], side=8, iters=80, ridge=1e-6)
    for sampler, target in ((a, ta), (b, tb)):
        err = (sampler.render(fitted) - target).pow(2).mean()
        assert err < 1e-3 * target.pow(2).mean()
    unweighted = fit_sprites([a, b], [ta, corrupt], None, side=8, iters=80, ridge=1e-6)
    assert (b.render(unweighted) - tb).pow(2).mean() > 100 * (b.render(fitted) - tb).pow(2).mean()
    single = fit_sprites([a], [ta], None, side=8, iters=80, ridge=1e-6)
    torch.testing.assert_close(single, a.fit(ta, side=8, iters=80, ridge=1e-6))


def test_detail_turns_with_its_texton():
    t = random_textons(10, seed=3)
    sprites = torch.randn(1, 10, 3, 8, 8, generator=torch.Generator().manual_seed(4))
    a = render_detail(t, sprites, (32, 32), cutoff=3.0)
    turned = t.rotate(90.0, center=(0.5, 0.5))
    b = render_detail(turned, sprites, (32, 32), cutoff=3.0)
    # the same picture, turned by 90 degrees (y down: +90 turns x towards y)
    diff = min((torch.rot90(a, k, dims=(-2, -1)) - b).abs().mean().item() for k in (1, -1))
    assert diff < 0.05 * a.abs().mean().item()
    assert (a - b).abs().mean() > 0.3 * a.abs().mean()  # and not a trivially symmetric one


def test_detail_fades_where_no_texton_reaches():
    t = random_textons(1)
    t.mu[:] = torch.tensor([0.2, 0.2])
    t.cov[:] = torch.eye(2) * 1e-3
    d = render_detail(t, torch.ones(1, 1, 3, 4, 4), (32, 32), cutoff=3.0)
    assert d[..., -4:, -4:].abs().max() == 0 and d.abs().max() > 0.5
    assert math.isclose(float(d[0, 0, 6, 6]), 1.0, rel_tol=0.05)  # full weight at the centre


def test_sprites_resample_to_another_side():
    from neuraltex.texton_detail import resize_sprites

    t = random_textons(3)
    flat = torch.full((1, 3, 3, 4, 4), 0.25)
    big = split(resize_sprites(attach(t, flat), 4, 8), 4)[1]
    assert big.shape == (1, 3, 3, 8, 8) and torch.allclose(big, torch.full_like(big, 0.25))
    blank = split(resize_sprites(t, 4, 8), 4)[1]
    assert blank.shape == (1, 3, 3, 8, 8) and blank.abs().max() == 0
