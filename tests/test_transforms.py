import torch

from conftest import make_textons
from neuraltex.splatting import splat
from train.transforms import Affine, random_affine, warp_images


def test_warping_the_splat_equals_splatting_the_transformed_textons():
    size = 64
    t = make_textons(B=2, K=6, C=3, seed=3, scale=0.05)
    t.mu = 0.3 + 0.4 * t.mu
    T = random_affine(2, (1.0, 1.0), generator=torch.Generator().manual_seed(0))
    base = splat(t, (size, size)).max_opacity
    warped, valid = warp_images(base, T)
    direct = splat(t.affine(T.A.unsqueeze(1), T.t.unsqueeze(1)), (size, size)).max_opacity
    err = (warped - direct).abs()[valid.bool()]
    assert err.mean() < 0.01 and (direct - base).abs().mean() > 0.02


def test_identity_and_pure_shift():
    img = torch.rand(1, 3, 16, 16)
    eye = Affine(torch.eye(2)[None], torch.zeros(1, 2))
    out, valid = warp_images(img, eye)
    assert torch.allclose(out, img, atol=1e-5) and valid.all()
    shift = Affine(torch.eye(2)[None], torch.tensor([[2 / 16, 0.0]]))  # 2 px right
    out, valid = warp_images(img, shift)
    assert torch.allclose(out[..., 2:], img[..., :-2], atol=1e-5)
    assert not valid[..., :2].any()
