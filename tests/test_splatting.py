import math

import kornia
import pytest
import torch

from conftest import make_textons, single
from neuraltex.coords import pixel_grid
from neuraltex.splatting import opacity_maps, splat, splat_reference, weighted_sums
from neuraltex.textons import Textons


def _grid_value(img: torch.Tensor, x: float, y: float, size: int) -> torch.Tensor:
    """Pixel whose centre is (x, y) on a size x size image."""
    j, i = round(x * size - 0.5), round(y * size - 0.5)
    return img[..., i, j]


def test_single_gaussian_peak_and_level_set():
    # Pixel centres at (j + .5)/64; put mu and the M = 1 points exactly on pixel centres.
    size = 64
    mu = (20.5 / size, 30.5 / size)
    # Axis-aligned U with std 4 px in x and 8 px in y, then rotated by 90 deg (swaps them).
    cov = [[(8 / size) ** 2, 0.0], [0.0, (4 / size) ** 2]]
    out = splat(single(mu, cov, f=(2.0,)), (size, size))
    fmax = out.max_opacity[0, 0]
    peak = torch.nonzero(fmax == fmax.max())[0].tolist()
    assert peak == [30, 20]
    assert fmax.max() == pytest.approx(1.0)
    # M = 1 along the axes: 8 px right/left, 4 px up/down.
    for dx, dy in ((8, 0), (-8, 0), (0, 4), (0, -4)):
        val = fmax[30 + dy, 20 + dx]
        assert val == pytest.approx(math.exp(-1), rel=1e-5)
    # Inside the ellipse opacity exceeds e^-1, outside it is below.
    assert fmax[30, 20 + 7] > math.exp(-1) > fmax[30, 20 + 9]
    assert fmax[30 + 3, 20] > math.exp(-1) > fmax[30 + 5, 20]
    # Features are opacity * concat(f, v) for a single Gaussian (alpha = o).
    assert torch.allclose(out.features[0, 0], 2.0 * fmax)
    assert torch.allclose(out.features[0, 1], fmax)  # v = (1, 0)


def _two(order_a: int, order_b: int) -> Textons:
    a = single((0.4, 0.5), [[0.01, 0.0], [0.0, 0.01]], f=(1.0,), order=order_a)
    b = single((0.6, 0.5), [[0.01, 0.0], [0.0, 0.01]], f=(-1.0,), order=order_b)
    return Textons.cat([a, b], dim=1, on_top=False)


def test_front_gaussian_occludes_per_eq_4_13():
    size = 40
    t = _two(0, 1)  # b (f = -1) in front
    out = splat(t, (size, size))
    grid = pixel_grid(size, size, dtype=torch.float64)
    o = []
    for k in range(2):
        d = grid - t.mu[0, k]
        m2 = (d @ torch.linalg.inv(t.cov[0, k]) * d).sum(-1)
        o.append(torch.exp(-m2))
    expected = -o[1] + o[0] * (1 - o[1])  # a_b = o_b, a_a = o_a (1 - o_b)
    assert torch.allclose(out.features[0, 0].reshape(-1), expected, atol=1e-6)


def test_reversing_draw_order_changes_only_the_overlap():
    size = 49  # odd: the midpoint between the two centres is a pixel centre
    front_b = splat(_two(0, 1), (size, size)).features[0, 0]
    front_a = splat(_two(1, 0), (size, size)).features[0, 0]
    o = opacity_maps(_two(0, 1), (size, size), composite=False)[0]
    overlap = (o[0] > 1e-3) & (o[1] > 1e-3)
    alone = (o[0] < 1e-7) | (o[1] < 1e-7)
    assert (front_a - front_b)[overlap].abs().max() > 0.1
    assert (front_a - front_b)[alone].abs().max() < 1e-6
    # In the middle, the front texton wins: f = -1 when b is in front, +1 when a is.
    mid = front_b[size // 2, size // 2], front_a[size // 2, size // 2]
    assert mid[0] < 0 < mid[1]


@pytest.mark.parametrize("cutoff", [None, 2.0])
@pytest.mark.parametrize("keep", [True, False], ids=["kept", "recomputed"])
@pytest.mark.parametrize("chunk_elements", [1 << 21, 600], ids=["one-chunk", "chunks"])
def test_fast_path_matches_reference_forward_and_backward(cutoff, keep, chunk_elements,
                                                          monkeypatch):
    """Both backward paths (the forward's opacities kept, or recomputed chunk by chunk)
    give the reference's values and gradients."""
    import neuraltex.splatting as sp

    monkeypatch.setattr(sp, "_KEEP_ELEMENTS", 1 << 24 if keep else 0)
    monkeypatch.setattr(sp, "_CHUNK_ELEMENTS", chunk_elements)
    t = make_textons(B=2, K=9, C=5, dtype=torch.float64, seed=3, scale=0.08)
    leaves = {k: getattr(t, k).requires_grad_(True) for k in ("mu", "cov", "f", "v", "delta")}
    size = (23, 37)  # odd, non-square: tiles overhang the border
    fast, ref = splat(t, size, cutoff=cutoff), splat_reference(t, size, cutoff=cutoff)
    assert torch.allclose(fast.features, ref.features, atol=1e-9)
    assert torch.allclose(fast.max_opacity, ref.max_opacity, atol=1e-9)
    w = torch.randn_like(fast.features)
    grads = []
    for out in (fast, ref):
        loss = (out.features * w).sum() + out.max_opacity.sum()
        grads.append(torch.autograd.grad(loss, list(leaves.values())))
    for name, a, b in zip(leaves, *grads, strict=True):
        assert torch.allclose(a, b, atol=1e-8, rtol=1e-6), name


def test_float32_gradients_follow_float64():
    """The backward's precision and mean gradients come from pixel moments (one product
    instead of five passes); in float32 they stay within 1e-4 of float64's."""
    from dataclasses import replace

    t64 = make_textons(B=2, K=60, C=8, dtype=torch.float64, seed=0, scale=0.05)
    grads = {}
    for dt in (torch.float64, torch.float32):
        leaves = {k: getattr(t64, k).detach().to(dt).requires_grad_(True)
                  for k in ("mu", "cov", "f", "delta")}
        t = replace(t64, **leaves, v=t64.v.to(dt), p=t64.p.to(dt))
        out = splat(t, (96, 80))
        w = torch.randn(out.features.shape, dtype=torch.float64,
                        generator=torch.Generator().manual_seed(1)).to(dt)
        loss = (out.features * w).sum() + out.max_opacity.sum()
        grads[dt] = torch.autograd.grad(loss, list(leaves.values()))
    for a, b in zip(grads[torch.float64], grads[torch.float32], strict=True):
        assert (a - b.double()).norm() < 1e-4 * a.norm()


def test_gradcheck_splat():
    t = make_textons(B=1, K=3, C=2, dtype=torch.float64, seed=1, scale=0.2)
    names = ("mu", "cov", "f", "delta")

    def fn(mu, cov, f, delta):
        cov = 0.5 * (cov + cov.transpose(-1, -2))
        tt = Textons(mu=mu, cov=cov, v=t.v, f=f, p=t.p, delta=delta, order=t.order)
        out = splat(tt, (6, 7))
        return out.features, out.max_opacity

    inputs = tuple(getattr(t, k).clone().requires_grad_(True) for k in names)
    assert torch.autograd.gradcheck(fn, inputs, atol=1e-6)


def test_integer_translation_equals_shifted_map():
    size = 32
    t = make_textons(B=1, K=6, C=3, seed=5, scale=0.06)
    t.mu = 0.25 + 0.5 * t.mu  # keep away from the borders
    base = splat(t, (size, size)).features
    moved = splat(t.translate(3 / size, -2 / size), (size, size)).features
    # Textons 3 px right and 2 px up: moved[y, x] == base[y + 2, x - 3].
    assert torch.allclose(moved[..., :-2, 3:], base[..., 2:, :-3], atol=1e-5)


def test_rotation_equals_rotated_map():
    size = 64
    t = make_textons(B=1, K=6, C=3, seed=6, scale=0.05)
    t.mu = 0.3 + 0.4 * t.mu
    base = splat(t, (size, size))
    # 90 deg about the centre maps pixel centres to pixel centres: exact.
    rot = splat(t.rotate(90), (size, size))
    assert torch.allclose(rot.max_opacity, torch.rot90(base.max_opacity, 1, dims=(2, 3)),
                          atol=1e-5)
    # 30 deg: compare against kornia's image rotation (same sign convention), up to
    # bilinear interpolation error.
    rot30 = splat(t.rotate(30), (size, size)).max_opacity
    ref = kornia.geometry.transform.rotate(base.max_opacity, torch.tensor([30.0]))
    change = (rot30 - base.max_opacity).abs().mean()
    assert (rot30 - ref).abs().mean() < 0.05 * change


def test_scale_about_centre_matches_resampled_map():
    size = 64
    t = make_textons(B=1, K=4, C=2, seed=7, scale=0.04)
    t.mu = 0.35 + 0.3 * t.mu
    big = splat(t.scale(2.0), (size, size)).max_opacity
    # Scaling the textons by 2 about the centre == rendering the central half window.
    crop = splat(t, (size, size), window=(0.25, 0.25, 0.75, 0.75)).max_opacity
    assert torch.allclose(big, crop, atol=1e-5)


def test_degenerate_covariances_stay_finite():
    t = make_textons(B=1, K=4, C=2, seed=2)
    t.cov[0, 0] = torch.tensor([[1.0, 1.0], [1.0, 1.0]])      # singular
    t.cov[0, 1] = torch.tensor([[1e-12, 0.0], [0.0, 1e-12]])  # vanishing
    t.cov[0, 2] = torch.tensor([[1e8, 0.0], [0.0, 1e8]])      # huge
    t.cov[0, 3] = torch.tensor([[1e-3, 1e-3 - 1e-9], [1e-3 - 1e-9, 1e-3]])  # nearly singular
    for k in ("mu", "cov", "f", "delta"):
        getattr(t, k).requires_grad_(True)
    out = splat(t, (16, 16))
    (out.features.sum() + out.max_opacity.sum()).backward()
    assert torch.isfinite(out.features).all() and torch.isfinite(out.max_opacity).all()
    for k in ("mu", "cov", "f", "delta"):
        assert torch.isfinite(getattr(t, k).grad).all(), k


def test_cutoff_zeroes_opacity_beyond_radius():
    size = 64
    t = single((0.5, 0.5), [[0.01, 0.0], [0.0, 0.01]])
    o = splat(t, (size, size), cutoff=1.5).max_opacity[0, 0]
    grid = pixel_grid(size, size, dtype=torch.float64).reshape(size, size, 2)
    m = ((grid - 0.5) ** 2).sum(-1).sqrt() / 0.1
    assert (o[m > 1.5] == 0).all() and (o[m < 1.4] > 0).all()


def test_any_resolution_gives_the_same_picture():
    t = make_textons(B=1, K=5, C=2, seed=8, scale=0.1)
    small = splat(t, (32, 32)).features
    big = splat(t, (64, 64)).features
    down = torch.nn.functional.avg_pool2d(big, 2)
    assert (small - down).abs().mean() < 0.02


def test_windows_tile_the_full_render():
    t = make_textons(B=2, K=5, C=2, seed=9)
    full = splat(t, (20, 40), window=(0, 0, 2, 1)).features
    left = splat(t, (20, 20), window=(0, 0, 1, 1)).features
    right = splat(t, (20, 20), window=(1, 0, 2, 1)).features
    assert torch.allclose(full, torch.cat([left, right], dim=-1), atol=1e-6)


def test_composited_opacity_maps_sum_to_at_most_one():
    t = make_textons(B=1, K=6, C=2, seed=4)
    t.delta = torch.ones_like(t.delta)
    a = opacity_maps(t, (24, 24))
    assert a.min() >= 0 and a.sum(1).max() <= 1 + 1e-6
    # Reassembling features from the maps reproduces the splat.
    feats = torch.einsum("bkhw,bkc->bchw", a, t.features())
    assert torch.allclose(feats, splat(t, (24, 24)).features, atol=1e-5)


@pytest.mark.parametrize("cutoff", [None, 3.0])
def test_weighted_sums_match_the_materialized_weights(cutoff):
    t = make_textons(B=2, K=9, C=5, dtype=torch.float64, seed=4, scale=0.08)
    values = torch.rand(2, 3, 20, 24, dtype=torch.float64)
    a = opacity_maps(t, (20, 24), cutoff=cutoff)  # (B, K, H, W), composited
    want = torch.einsum("bkhw,bchw->bkc", a, values)
    torch.testing.assert_close(weighted_sums(t, values, cutoff=cutoff), want)
