import torch

from train.mask_supervision import mask_supervision_loss, pairwise_dice_bce


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
    T = (torch.rand(4, 50) > 0.5).float()
    c = pairwise_dice_bce(T.clamp(1e-4, 1 - 1e-4), T)
    assert torch.equal(c.argmin(dim=1), torch.arange(4))
