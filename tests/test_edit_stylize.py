from types import SimpleNamespace

import torch

from neuraltex.edit.stylize import content_textons, merge_patches, patch_starts
from neuraltex.textons import Textons


def _lattice(n: int = 8, size: float = 1.5) -> Textons:
    """n x n effective textons on a regular lattice over a size x 1 canvas."""
    xs = (torch.arange(n) + 0.5) / n
    gy, gx = torch.meshgrid(xs, xs, indexing="ij")
    mu = torch.stack([gx.flatten() * size, gy.flatten()], -1)[None]  # (1, n*n, 2)
    K = mu.shape[1]
    return Textons(mu=mu, cov=torch.eye(2).expand(1, K, 2, 2) * 1e-3,
                   v=torch.tensor([1.0, 0.0]).expand(1, K, 2), f=torch.randn(1, K, 3),
                   p=torch.ones(1, K), delta=torch.ones(1, K),
                   order=torch.arange(K)[None], canvas=(size, 1.0))


def test_patch_starts_cover_the_length_and_end_flush():
    assert patch_starts(100, 40, 30) == [0, 30, 60]
    assert patch_starts(30, 40, 30) == [0]


def test_merging_patches_of_one_texture_gives_it_back():
    whole = _lattice()
    short, side = 64, 32
    boxes = [(y, x, side) for y in patch_starts(64, side, 24) for x in patch_starts(96, side, 24)]
    sets = [whole.filter(whole.in_region((x / short, y / short, (x + side) / short,
                                          (y + side) / short))) for y, x, _ in boxes]
    merged = merge_patches(Textons.cat(sets, dim=0), boxes, short)
    key = lambda m: sorted(map(tuple, m.round(decimals=5).tolist()))  # noqa: E731
    assert key(merged.mu[0]) == key(whole.mu[0])  # every texton once, in place


def test_scale_control_shrinks_textons():
    def encode(crops):  # one texton in the middle of every patch, patch units
        b = crops.shape[0]
        return SimpleNamespace(textons=Textons(
            mu=torch.full((b, 1, 2), 0.5), cov=torch.eye(2).expand(b, 1, 2, 2) * 0.01,
            v=torch.tensor([1.0, 0.0]).expand(b, 1, 2), f=torch.ones(b, 1, 2),
            p=torch.ones(b, 1), delta=torch.ones(b, 1), order=torch.zeros(b, 1)))

    model, image = SimpleNamespace(encode=encode), torch.rand(3, 64, 96)
    full = content_textons(model, image, patch=32, scale=1.0, overlap=0.0)
    half = content_textons(model, image, patch=32, scale=0.5, overlap=0.0)
    assert full.num_textons == 6 and half.num_textons == 24 and full.canvas == (1.5, 1.0)
    assert torch.allclose(full.cov[0, 0], torch.eye(2) * 0.01 * 0.5 ** 2)
    assert torch.allclose(half.cov[0, 0], torch.eye(2) * 0.01 * 0.25 ** 2)
    assert torch.allclose(half.mu[0, 0], torch.tensor([0.125, 0.125]))
