"""Colour-guided refinement of E_s's masks (neuraltex/mask_refinement.py, issue 16)."""

import pytest
import torch

from neuraltex.mask_refinement import colour_guided_labels

RED, BLUE, GREEN = (0.9, 0.1, 0.1), (0.1, 0.1, 0.9), (0.1, 0.9, 0.1)


def _image(cols: list[tuple[float, float, float]], H: int = 8) -> torch.Tensor:
    return torch.tensor(cols).T[:, None, :].expand(3, H, len(cols)).contiguous()


def _soft_edge(W: int, at: float, K: int = 2) -> torch.Tensor:
    """Masks (K, 8, W): label 0 left of ``at``, label 1 right of it, a soft ramp between."""
    x = torch.arange(W).float()
    left = torch.sigmoid((at - 0.5 - x) / 2)[None].expand(8, W)
    masks = torch.zeros(K, 8, W)
    masks[0], masks[1] = left, 1 - left
    return masks


def test_the_edge_snaps_to_the_colour_edge():
    W = 40
    image = _image([RED] * 20 + [BLUE] * 20)  # the true edge: between x = 19 and 20
    masks = _soft_edge(W, 24)                   # the masks put it 4 px too far right
    truth = (torch.arange(W) >= 20).long().expand(8, W)
    assert (colour_guided_labels(masks, image, weight=0) != truth).any()  # S's argmax: off
    assert torch.equal(colour_guided_labels(masks, image), truth)


def test_a_label_does_not_jump_to_a_far_region_of_its_colour():
    W = 40
    cols = [GREEN] * 4 + [RED] * 16 + [BLUE] * 20
    cols[30] = GREEN  # a green speck inside the blue region, far from label 2's green
    image = _image(cols)
    masks = _soft_edge(W, 20, K=3)
    masks[2, :, :4], masks[0, :, :4] = 1.0, 0.0  # label 2: the green strip at the left
    labels = colour_guided_labels(masks, image)
    assert (labels[:, :4] == 2).all() and (labels[:, 30] == 1).all()
    # without the reach (every label a candidate everywhere) the speck goes to the far label
    assert (colour_guided_labels(masks, image, reach=0.0)[:, 30] == 2).all()


def test_chunks_do_not_change_the_labels():
    g = torch.Generator().manual_seed(0)
    masks = torch.rand(5, 12, 17, generator=g).softmax(0)
    image = torch.rand(3, 12, 17, generator=g)
    assert torch.equal(colour_guided_labels(masks, image),
                       colour_guided_labels(masks, image, chunk=7))


def test_a_mismatched_image_is_refused():
    with pytest.raises(ValueError, match="image must be"):
        colour_guided_labels(torch.rand(2, 4, 4), torch.rand(3, 4, 5))
