import pytest
import torch

from neuraltex.edit.propagate import align_gaussians, propagate_edit
from neuraltex.errors import InputError
from neuraltex.textons import Textons


def _three_textons() -> Textons:
    """A source, a similar target turned by 90 degrees, and a dissimilar texton (64 px)."""
    t = lambda x: torch.tensor([x], dtype=torch.float32)  # noqa: E731
    return Textons(mu=t([[0.25, 0.25], [0.75, 0.7], [0.75, 0.2]]),
                   cov=t([[[0.01, 0], [0, 0.0025]], [[0.0025, 0], [0, 0.01]],
                          [[0.01, 0], [0, 0.0025]]]),
                   v=t([[1.0, 0.0], [0.0, 1.0], [1.0, 0.0]]),
                   f=t([[1.0, 0.0], [1.0, 0.05], [0.0, 1.0]]),
                   p=t([1.0, 1.0, 1.0]), delta=t([1.0, 1.0, 1.0]), order=torch.tensor([[0, 1, 2]]))


def test_align_gaussians_maps_shape_and_direction():
    g = torch.Generator().manual_seed(0)
    M = torch.randn(2, 5, 2, 2, generator=g, dtype=torch.float64)
    cov = M @ M.transpose(-1, -2) + 0.1 * torch.eye(2, dtype=torch.float64)
    v = torch.randn(2, 5, 2, generator=g, dtype=torch.float64)
    v = torch.nn.functional.normalize(v, dim=-1)
    A = align_gaussians(cov[0], v[0], cov[1], v[1])
    assert torch.allclose(A @ cov[0] @ A.transpose(-1, -2), cov[1], atol=1e-10)
    Av = (A @ v[0].unsqueeze(-1)).squeeze(-1)
    assert torch.allclose(torch.nn.functional.normalize(Av, dim=-1), v[1], atol=1e-10)


def test_edit_is_repeated_on_the_similar_texton_only():
    textons = _three_textons()
    original = torch.zeros(3, 64, 64)
    edited = original.clone()
    edited[:, 14:18, 18:22] = 1.0  # a dot 0.05 right of the source centre (16, 16 px)
    out = propagate_edit(original, edited, textons, threshold=0.9)
    assert out.source == 0 and out.targets.tolist() == [False, True, False]
    # A carries +0.05 along x at the source to +0.05 along y at the target: pixel (48, 48)
    # is the target centre (0.75, 0.7) -> (48, 44.8); the dot lands around (48, 48).
    assert out.image[0, 46:50, 46:50].mean() > 0.5
    assert torch.equal(out.image[:, 14:18, 18:22], edited[:, 14:18, 18:22])
    assert out.image[:, :32, 40:].abs().sum() == 0  # nothing near the dissimilar texton 2


def test_unchanged_image_is_an_input_error():
    with pytest.raises(InputError, match="does not differ"):
        propagate_edit(torch.zeros(3, 64, 64), torch.zeros(3, 64, 64), _three_textons())
    with pytest.raises(InputError, match="same size"):
        propagate_edit(torch.zeros(3, 64, 64), torch.zeros(3, 32, 64), _three_textons())
