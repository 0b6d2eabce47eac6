import math

import pytest
import torch

from neuraltex.coords import pixel_grid
from neuraltex.estimation import estimate_textons


def _maps(masks: torch.Tensor, C: int = 3, seed: int = 0):
    B, _, H, W = masks.shape
    g = torch.Generator().manual_seed(seed)
    return (torch.randn(B, C, H, W, generator=g, dtype=masks.dtype),
            torch.randn(B, 2, H, W, generator=g, dtype=masks.dtype))


def _two_region_masks(inside: torch.Tensor) -> torch.Tensor:
    """Hard masks: query 0 = region, query 1 = the rest. (1, 2, H, W) float64."""
    m = inside.double()
    return torch.stack([m, 1 - m]).unsqueeze(0)


def test_rectangle_mask_gives_discrete_uniform_mean_and_covariance():
    H, W, eps = 40, 60, 1e-5  # S = 40, W spans [0, 1.5]
    inside = torch.zeros(H, W, dtype=torch.bool)
    inside[5:15, 10:40] = True  # 10 rows x 30 columns
    t = estimate_textons(_two_region_masks(inside), *_maps(torch.zeros(1, 2, H, W).double()),
                         eps=eps)
    S = 40.0
    assert t.mu[0, 0].tolist() == pytest.approx([25.0 / S, 10.0 / S])  # centre of cols/rows
    # Variance of m equally spaced pixel centres with pitch 1/S: (m^2 - 1) / 12 / S^2.
    var_x, var_y = (30 ** 2 - 1) / 12 / S ** 2, (10 ** 2 - 1) / 12 / S ** 2
    expected = torch.tensor([[var_x + eps, 0.0], [0.0, var_y + eps]], dtype=torch.float64)
    assert torch.allclose(t.cov[0, 0], expected, atol=1e-12)
    assert t.canvas == (1.5, 1.0)


def test_rotated_ellipse_mask_matches_analytic_covariance():
    size, a, b, angle = 128, 0.3, 0.12, math.radians(35)
    grid = pixel_grid(size, size, dtype=torch.float64).reshape(size, size, 2) - 0.5
    R = torch.tensor([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]],
                     dtype=torch.float64)
    local = grid @ R  # coordinates in the ellipse frame
    inside = (local[..., 0] / a) ** 2 + (local[..., 1] / b) ** 2 <= 1
    t = estimate_textons(_two_region_masks(inside),
                         *_maps(torch.zeros(1, 2, size, size).double()), eps=0.0)
    # A solid ellipse with semi-axes a, b has covariance R diag(a^2/4, b^2/4) R^T.
    expected = R @ torch.diag(torch.tensor([a * a / 4, b * b / 4], dtype=torch.float64)) @ R.T
    assert torch.allclose(t.mu[0, 0], torch.tensor([0.5, 0.5], dtype=torch.float64), atol=1e-3)
    assert torch.allclose(t.cov[0, 0], expected, rtol=0.03, atol=2e-4)


def test_existence_probability_hard_vs_uniform():
    H = W = 16
    n = 8
    hard = torch.zeros(1, n, H, W)
    labels = torch.arange(H * W).reshape(H, W) % n
    hard.scatter_(1, labels[None, None], 1.0)
    t = estimate_textons(hard, *_maps(hard))
    assert torch.allclose(t.p, torch.ones(1, n))  # eq. 4.5 on one-hot masks
    assert (t.delta == 1).all()
    uniform = torch.full((1, n, H, W), 1.0 / n)
    t = estimate_textons(uniform, *_maps(uniform))
    assert torch.allclose(t.p, torch.full((1, n), 1.0 / n))
    assert (t.delta == 0).all()  # rounding at inference switches them off


def test_features_and_directions_are_normalized_mask_averages():
    g = torch.Generator().manual_seed(1)
    masks = torch.randn(2, 4, 9, 11, generator=g).softmax(dim=1)
    app, direc = _maps(masks, C=5, seed=2)
    t = estimate_textons(masks, app, direc)
    w = masks / masks.sum(dim=(2, 3), keepdim=True)
    f = torch.einsum("bnhw,bchw->bnc", w, app)
    v = torch.einsum("bnhw,bchw->bnc", w, direc)
    assert torch.allclose(t.f, f / f.norm(dim=-1, keepdim=True), atol=1e-5)
    assert torch.allclose(t.v, v / v.norm(dim=-1, keepdim=True), atol=1e-5)
    assert torch.allclose(t.f.norm(dim=-1), torch.ones(2, 4))


def test_gumbel_existence_samples_bernoulli_with_straight_through_gradient():
    from neuraltex.estimation import _existence

    p = torch.full((1, 4000), 0.3)
    g = torch.Generator().manual_seed(0)
    logits = p.clone().requires_grad_(True)
    delta = _existence(logits, "sample", 0.5, g)
    assert set(delta.unique().tolist()) <= {0.0, 1.0}
    assert delta.mean().item() == pytest.approx(0.3, abs=0.03)
    delta.sum().backward()
    assert (logits.grad > 0).all()  # gradient flows although the forward value is hard


@pytest.mark.parametrize("existence", ["soft", "sample"])
def test_gradcheck_estimation(existence):
    # "sample" is a straight-through estimator: its delta is a step function, so only the
    # continuous outputs are checked there.
    g = torch.Generator().manual_seed(0)
    logits = torch.randn(1, 3, 5, 4, generator=g, dtype=torch.float64)
    app = torch.randn(1, 2, 5, 4, generator=g, dtype=torch.float64)
    direc = torch.randn(1, 2, 5, 4, generator=g, dtype=torch.float64)

    def fn(logits, app, direc):
        sampler = torch.Generator().manual_seed(3)  # same noise on every call
        t = estimate_textons(logits.softmax(dim=1), app, direc, existence=existence,
                             generator=sampler)
        out = (t.mu, t.cov, t.f, t.v, t.p)
        return out + (t.delta,) if existence == "soft" else out

    inputs = tuple(x.clone().requires_grad_(True) for x in (logits, app, direc))
    assert torch.autograd.gradcheck(fn, inputs, atol=1e-6)


def test_bad_shapes_are_rejected():
    masks = torch.rand(1, 3, 8, 8).softmax(1)
    with pytest.raises(ValueError, match="appearance"):
        estimate_textons(masks, torch.rand(1, 4, 8, 9), torch.rand(1, 2, 8, 8))
    with pytest.raises(ValueError, match="direction"):
        estimate_textons(masks, torch.rand(1, 4, 8, 8), torch.rand(1, 3, 8, 8))


def test_empty_masks_still_get_unit_directions():
    masks = torch.zeros(1, 3, 8, 8)
    masks[:, 0] = 1.0  # textons 1 and 2 have no pixels at all
    direction = torch.nn.functional.normalize(torch.randn(1, 2, 8, 8), dim=1)
    t = estimate_textons(masks, torch.randn(1, 4, 8, 8), direction)
    assert torch.allclose(t.v.norm(dim=-1), torch.ones(1, 3))


def test_background_is_drawn_behind_the_element_it_surrounds():
    from neuraltex.splatting import splat

    size = 32
    inside = torch.zeros(size, size, dtype=torch.bool)
    inside[12:20, 12:20] = True
    masks = _two_region_masks(inside).flip(1)  # query 0 = background, query 1 = the square
    t = estimate_textons(masks, *_maps(masks), existence="all")
    assert t.order[0].tolist() == [0, 1]  # the larger Gaussian gets the lower rank (behind)
    t = estimate_textons(masks.flip(1), *_maps(masks.flip(1)), existence="all")
    assert t.order[0].tolist() == [1, 0]  # whatever the query order
    # The element's own features win at its centre; in query order the background hid them.
    f = splat(t, (size, size)).features[0, :-2, 16, 16]
    to_square, to_background = (f - t.f[0, 0]).norm(), (f - t.f[0, 1]).norm()
    assert to_square < 0.2 * to_background
