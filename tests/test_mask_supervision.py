import torch

from train.mask_supervision import instance_targets, mask_supervision_loss, pairwise_dice_bce


def _labels():
    lab = torch.zeros(1, 12, 12, dtype=torch.long)
    lab[0, 2:6, 2:6] = 1
    lab[0, 7:11, 1:5] = 2
    lab[0, 3:9, 7:11] = 3
    return lab


def test_perfect_masks_in_any_query_order_score_lower_than_wrong_ones():
    lab = _labels()
    onehot = torch.nn.functional.one_hot(lab, 6).permute(0, 3, 1, 2).float()  # 6 queries
    perm = onehot[:, [4, 2, 0, 5, 3, 1]]  # same masks, other queries
    soft = (perm * 20).softmax(1)
    good = mask_supervision_loss(soft, lab)
    wrong = mask_supervision_loss(torch.roll(soft, 3, dims=-1), lab)
    uniform = mask_supervision_loss(torch.full_like(soft, 1 / 6), lab)
    assert good < 0.01 and wrong > 1.0 and uniform > 1.0


def test_gradient_pulls_matched_query_towards_its_segment():
    lab = _labels()
    logits = torch.zeros(1, 6, 12, 12, requires_grad=True)
    mask_supervision_loss(logits.softmax(1), lab).backward()
    assert torch.isfinite(logits.grad).all() and logits.grad.abs().sum() > 0


def test_pairwise_cost_minimal_on_identity():
    index = torch.randint(0, 4, (1, 60))
    T = torch.nn.functional.one_hot(index[0], 4).T.float()  # (4, 60) one segment per pixel
    c = pairwise_dice_bce(T.clamp(1e-4, 1 - 1e-4)[None], index, 4)[0]
    assert torch.equal(c.argmin(dim=1), torch.arange(4))


def test_instance_targets_keep_the_largest_segments():
    lab = torch.tensor([[[0, 0, 0, 1], [2, 2, 3, 3]], [[5, 5, 5, 5], [5, 5, 5, 5]]])
    index, valid = instance_targets(lab, 2)  # image 0: 0 (3 px), then 2 or 3 (2 px), 1 dropped
    assert valid.tolist() == [[True, True], [True, False]]
    assert index[0, :3].tolist() == [0, 0, 0] and index[0, 3] == 2  # 1 -> "no segment"
    assert (index[1] == 0).all()


def _reference_loss(masks, labels):
    """The plain per-image loop (one cost matrix and one assignment per image)."""
    from scipy.optimize import linear_sum_assignment

    B, n, H, W = masks.shape
    total = masks.new_zeros(())
    for b in range(B):
        S = masks[b].reshape(n, H * W)
        ids = torch.unique(labels[b])
        T = (labels[b].flatten()[None] == ids[:, None]).float()
        cost = torch.stack([torch.stack([
            1 - (2 * (s * t).sum() + 1) / (s.sum() + t.sum() + 1)
            - (t * s.clamp_min(1e-6).log() + (1 - t) * (1 - s).clamp_min(1e-6).log()).mean()
            for t in T]) for s in S])
        rows, cols = linear_sum_assignment(cost.detach().numpy())
        unmatched = torch.ones(n, dtype=torch.bool)
        unmatched[rows] = False
        empty = S[unmatched].mean() if unmatched.any() else S.new_zeros(())
        total = total + cost[rows, cols].mean() + empty
    return total / B


def test_batched_loss_equals_the_per_image_reference_with_gradients():
    torch.manual_seed(0)
    labels = torch.randint(0, 5, (3, 10, 10))
    labels[1][labels[1] > 2] = 0  # images with different numbers of segments
    labels[2] = 1
    logits = torch.randn(3, 6, 10, 10, dtype=torch.float64, requires_grad=True)
    _assert_equals_reference(logits, labels)


def _assert_equals_reference(logits, labels):
    """The loss of logits.softmax(1) and its gradient to the logits equal the reference's."""
    fast = mask_supervision_loss(logits.softmax(1), labels)
    (g_fast,) = torch.autograd.grad(fast, logits)
    ref = _reference_loss(logits.softmax(1), labels)
    (g_ref,) = torch.autograd.grad(ref, logits)
    assert torch.allclose(fast, ref, atol=1e-10)
    assert torch.allclose(g_fast, g_ref, atol=1e-10)


def test_bfloat16_masks_are_scored_in_float32():
    """Under bfloat16 autocast (trainer.amp) E_s hands over bfloat16 masks: the loss takes
    them (the Hungarian costs go through numpy) and is computed in float32, the same as for
    float32 masks up to the masks' rounding, with gradients back to the bfloat16 logits."""
    lab = _labels()
    logits = (torch.nn.functional.one_hot(lab, 6).permute(0, 3, 1, 2).float() * 4
              + torch.randn(1, 6, 12, 12, generator=torch.Generator().manual_seed(0)))
    half = logits.bfloat16().requires_grad_()
    loss = mask_supervision_loss(half.softmax(1), lab)
    ref = mask_supervision_loss(half.detach().float().softmax(1), lab)
    assert loss.dtype == torch.float32 and abs(float(loss.detach()) - float(ref)) < 0.02
    loss.backward()
    assert half.grad.dtype == torch.bfloat16 and torch.isfinite(half.grad.float()).all()


def test_logits_take_the_softmax_after_the_point_sampling():
    """``logits=True`` (the segmenter stage: the softmax over the queries only on the sampled
    pixels) gives the loss and gradients of the softmax taken first, for the same draw."""
    torch.manual_seed(0)
    labels = torch.randint(0, 4, (2, 16, 16))
    logits = torch.randn(2, 5, 16, 16, dtype=torch.float64, requires_grad=True)
    for points in (None, 40):
        first = mask_supervision_loss(logits.softmax(1), labels, points,
                                      torch.Generator().manual_seed(3))
        (g_first,) = torch.autograd.grad(first, logits)
        late = mask_supervision_loss(logits, labels, points, torch.Generator().manual_seed(3),
                                     logits=True)
        (g_late,) = torch.autograd.grad(late, logits)
        assert torch.allclose(first, late, atol=1e-12)
        assert torch.allclose(g_first, g_late, atol=1e-12)
        if points:  # only the sampled pixels get a gradient
            assert 0 < int((g_late.abs().sum(1) > 0).sum()) <= 2 * points


def test_closed_form_gradient_where_the_clamps_cut_and_under_the_reference():
    """Near-one-hot masks (many probabilities below eps = 1e-6 and above 1 - eps, where the
    BCE's clamps cut the gradient): the loss and its closed-form gradient equal autograd
    through the per-image reference."""
    torch.manual_seed(1)
    labels = torch.randint(0, 4, (2, 9, 9))
    logits = (torch.randn(2, 6, 9, 9, dtype=torch.float64) * 12).requires_grad_()
    S = logits.softmax(1)
    assert ((S < 1e-6).sum() > 50) and ((S > 1 - 1e-6).sum() > 10)
    _assert_equals_reference(logits, labels)


def test_gradient_checks_with_dropped_segments_unmatched_queries_and_points():
    """gradcheck (float64, finite differences) of the loss with more labels than queries (the
    smallest dropped), queries left unmatched in another image, and sampled points."""
    torch.manual_seed(2)
    labels = torch.randint(0, 7, (2, 8, 8))  # 7 labels, 5 queries: two dropped in image 0
    labels[1] = labels[1] % 2  # 2 segments: 3 queries unmatched
    logits = torch.randn(2, 5, 8, 8, dtype=torch.float64, requires_grad=True)

    def loss(x):
        return mask_supervision_loss(x, labels, 40, torch.Generator().manual_seed(0),
                                     logits=True)

    assert torch.autograd.gradcheck(loss, (logits,), eps=1e-6, atol=1e-7)
