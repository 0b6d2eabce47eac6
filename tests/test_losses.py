import math

import pytest
import torch

from conftest import make_textons
from neuraltex.losses import (
    ReconstructionLoss,
    compactness_loss,
    d_logistic_loss,
    d_r1_loss,
    entropy_loss,
    g_nonsaturating_loss,
    sliced_wasserstein_patches,
)
from train.consistency import consistency_loss, matching_cost


def test_entropy_zero_for_hard_masks_and_log_n_for_uniform():
    hard = torch.zeros(1, 4, 6, 6)
    hard[:, 0] = 1
    assert entropy_loss(hard) == pytest.approx(0.0, abs=1e-9)
    assert entropy_loss(torch.full((1, 4, 6, 6), 0.25)) == pytest.approx(math.log(4), rel=1e-5)


def test_compactness_prefers_compact_segments():
    from neuraltex.estimation import estimate_textons

    H = W = 16
    yy, xx = torch.meshgrid(torch.arange(H), torch.arange(W), indexing="ij")
    blocks = (yy // 4) * 4 + xx // 4         # 16 compact 4x4 segments
    scattered = (yy * W + xx) % 16           # 16 segments spread over the image
    losses = []
    for labels in (blocks, scattered):
        m = torch.nn.functional.one_hot(labels, 16).permute(2, 0, 1).float()[None]
        t = estimate_textons(m, torch.rand(1, 3, H, W), torch.rand(1, 2, H, W))
        losses.append(compactness_loss(m, t.mu).item())
    assert losses[0] < 0.2 * losses[1]


def test_reconstruction_loss_is_zero_on_identity_and_masks_pixels():
    from neuraltex.perceptual import _warn_random_trunk

    _warn_random_trunk.cache_clear()  # said once per process: an earlier test may have built one
    with pytest.warns(UserWarning, match="randomly initialized"):
        loss = ReconstructionLoss(backbone="auto")
    assert loss.lpips.backbone_used == "random"
    x = torch.rand(2, 3, 32, 32)
    assert loss(x, x).item() == pytest.approx(0.0, abs=1e-6)
    y = x.clone()
    y[..., :8] = 1 - y[..., :8]
    mask = torch.ones(2, 1, 32, 32)
    mask[..., :8] = 0
    assert ReconstructionLoss(w_lpips=0)(x, y, mask).item() == pytest.approx(0.0, abs=1e-6)
    assert loss(x, y).item() > 0.1
    with pytest.raises(FileNotFoundError, match="hub cache"):
        ReconstructionLoss(backbone="pretrained")


def test_sliced_wasserstein_ignores_layout_but_sees_colours():
    g = torch.Generator().manual_seed(0)
    x = torch.rand(1, 3, 32, 32, generator=g)
    rolled = torch.roll(x, shifts=(7, 11), dims=(2, 3))  # same patches, other places
    darker = x * 0.5
    kw = dict(patch=2, generator=torch.Generator().manual_seed(1))
    d_roll = sliced_wasserstein_patches(x, rolled, **kw).item()
    kw["generator"] = torch.Generator().manual_seed(1)
    d_dark = sliced_wasserstein_patches(x, darker, **kw).item()
    assert d_roll < 0.05 * d_dark


def test_sliced_wasserstein_runs_in_float32_under_autocast():
    """Under bfloat16 autocast the texture loss is the float32 one (bfloat16 projections
    would tie), value and gradient."""
    g = torch.Generator().manual_seed(3)
    x = torch.rand(2, 3, 24, 24, generator=g, requires_grad=True)
    y = torch.rand(2, 3, 24, 24, generator=g)
    out = []
    for amp in (False, True):
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=amp):
            loss = sliced_wasserstein_patches(x, y, patch=4,
                                              generator=torch.Generator().manual_seed(1))
        out.append((loss, torch.autograd.grad(loss, x)[0]))
    (l32, g32), (lamp, gamp) = out
    assert lamp.dtype == torch.float32 and lamp.item() == l32.item()
    assert torch.equal(gamp, g32)


def test_gan_losses_and_r1():
    zero = torch.zeros(4)
    assert d_logistic_loss(zero, zero).item() == pytest.approx(2 * math.log(2))
    assert g_nonsaturating_loss(zero).item() == pytest.approx(math.log(2))
    x = torch.rand(3, 2, 4, 4, requires_grad=True)
    w = torch.randn(2, 4, 4)
    pred = (x * w).flatten(1).sum(1)  # D(x) = <w, x>, so grad = w
    assert d_r1_loss(pred, x).item() == pytest.approx(w.square().sum().item(), rel=1e-5)


def test_consistency_is_zero_for_a_permuted_copy_and_positive_otherwise():
    t = make_textons(B=1, K=6, C=3, seed=2)
    t.p = torch.ones_like(t.p)
    masks = torch.rand(1, 6, 8, 8).softmax(1)
    perm = torch.tensor([3, 0, 5, 1, 2, 4])
    shuffled = t.index(perm)
    assert consistency_loss(t, shuffled, masks, masks[:, perm]).item() == pytest.approx(0, abs=1e-5)
    moved = t.translate(0.05, 0.0)
    assert consistency_loss(t, moved, masks, masks).item() > 0.1
    cost = matching_cost(t, shuffled, masks, masks[:, perm])
    assert torch.equal(cost[0].argmin(dim=1), torch.argsort(perm))
    # Textons marked invalid are left out: with none valid the loss vanishes.
    none = torch.zeros(1, 6, dtype=torch.bool)
    assert consistency_loss(t, moved, masks, masks, valid=none).item() == 0


def test_consistency_mean_is_the_sum_over_matched_pairs():
    t = make_textons(B=2, K=6, C=3, seed=3)
    moved = t.translate(0.05, 0.0)
    masks = torch.rand(2, 6, 8, 8, generator=torch.Generator().manual_seed(0)).softmax(1)
    s = consistency_loss(moved, t, masks, masks)
    m = consistency_loss(moved, t, masks, masks, reduce="mean")
    assert m.item() == pytest.approx(s.item() / 6, rel=1e-5)
    with pytest.raises(ValueError):
        consistency_loss(moved, t, masks, masks, reduce="max")


@pytest.mark.parametrize("reduce", ["sum", "mean"])
def test_consistency_gradient_is_that_of_the_matched_entries_of_the_cost_matrix(reduce):
    """The loss recomputes only the matched pairs: its value and gradients (textons and masks
    of both sides) equal those of the Hungarian-matched entries of the full eq. 4.21 matrix,
    with rows left out by ``valid``; ``pair_cost`` is the matrix's diagonal."""
    from scipy.optimize import linear_sum_assignment

    from train.consistency import pair_cost

    g = torch.Generator().manual_seed(4)
    a0 = make_textons(B=3, K=7, C=3, seed=5, dtype=torch.float64)
    b0 = make_textons(B=3, K=7, C=3, seed=6, dtype=torch.float64)
    ma0 = torch.rand(3, 7, 5, 5, generator=g, dtype=torch.float64).softmax(1)
    mb0 = torch.rand(3, 7, 5, 5, generator=g, dtype=torch.float64).softmax(1)
    valid = torch.rand(3, 7, generator=g) > 0.3
    valid[1] = False  # a set with no valid texton adds nothing
    valid[2, :2] = True

    def leaves():
        fields = [x.clone().requires_grad_(True) for t in (a0, b0)
                  for x in (t.mu, t.cov, t.v, t.f, t.p)] + [ma0.clone().requires_grad_(True),
                                                             mb0.clone().requires_grad_(True)]
        a = type(a0)(*fields[:5], delta=a0.delta, order=a0.order)
        b = type(b0)(*fields[5:10], delta=b0.delta, order=b0.order)
        return fields, a, b, fields[10], fields[11]

    fields, a, b, ma, mb = leaves()
    loss = consistency_loss(a, b, ma, mb, valid=valid, reduce=reduce)
    got = torch.autograd.grad(loss, fields)
    fields, a, b, ma, mb = leaves()
    cost = matching_cost(a, b, ma, mb)
    ref = cost.new_zeros(())
    for i in range(3):
        rows = torch.nonzero(valid[i]).squeeze(1)
        if len(rows):
            r, c = linear_sum_assignment(cost[i, rows].detach().numpy())
            matched = cost[i, rows[r], c]
            ref = ref + (matched.sum() if reduce == "sum" else matched.mean())
    ref = ref / 3
    assert loss.item() == pytest.approx(ref.item(), rel=1e-12)
    for x, y in zip(got, torch.autograd.grad(ref, fields), strict=True):
        assert torch.allclose(x, y, atol=1e-12)
    assert torch.allclose(pair_cost(a, b, ma, mb), cost.diagonal(dim1=1, dim2=2), atol=1e-12)
