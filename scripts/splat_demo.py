"""Render a picture of Gaussian splatting: textons whose features are RGB colours.

    python scripts/splat_demo.py --out docs/splat_demo.png

Panels: F_max at 64 px | features at 64 px | the same textons at 256 px (resolution
independence) | rotated 30 deg and scaled 1.3x about the centre | draw order reversed.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image

from neuraltex.fileio import atomic_path
from neuraltex.splatting import splat
from neuraltex.textons import Textons


def demo_textons(n_side: int = 7, seed: int = 0) -> Textons:
    """A jittered grid of overlapping, randomly oriented ellipses with RGB 'features'."""
    g = torch.Generator().manual_seed(seed)
    k = n_side * n_side
    ij = torch.stack(torch.meshgrid(torch.arange(n_side), torch.arange(n_side), indexing="ij"))
    mu = (ij.reshape(2, -1).T.flip(-1).float() + 0.5) / n_side
    mu = mu + (torch.rand(k, 2, generator=g) - 0.5) * 0.6 / n_side
    angle = torch.rand(k, generator=g) * math.pi
    R = torch.stack([torch.cos(angle), -torch.sin(angle), torch.sin(angle), torch.cos(angle)], -1)
    R = R.reshape(k, 2, 2)
    s = (0.5 + torch.rand(k, 2, generator=g)) / n_side * torch.tensor([0.5, 0.22])
    cov = R @ torch.diag_embed(s ** 2) @ R.transpose(1, 2)
    colour = torch.rand(k, 3, generator=g) * 0.8 + 0.2
    v = torch.stack([torch.cos(angle), torch.sin(angle)], -1)
    return Textons(mu=mu[None], cov=cov[None], v=v[None], f=colour[None],
                   p=torch.ones(1, k), delta=torch.ones(1, k), order=torch.arange(k)[None])


def to_rgb(out, size: int) -> np.ndarray:
    rgb = out.features[0, :3]
    rgb = F.interpolate(rgb[None], size=(size, size), mode="nearest")[0]
    return (rgb.clamp(0, 1).permute(1, 2, 0).numpy() * 255).astype(np.uint8)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--out", default="docs/splat_demo.png")
    args = ap.parse_args()
    t = demo_textons()
    size = 256
    low = splat(t, (64, 64))
    fmax = low.max_opacity[0].expand(3, -1, -1)
    fmax_img = F.interpolate(fmax[None], size=(size, size), mode="nearest")[0]
    panels = [
        (fmax_img.permute(1, 2, 0).numpy() * 255).astype(np.uint8),
        to_rgb(low, size),
        to_rgb(splat(t, (size, size)), size),
        to_rgb(splat(t.rotate(30).scale(1.3), (size, size)), size),
        to_rgb(splat(Textons(**{**t.__dict__, "order": t.order.flip(1)}), (size, size)), size),
    ]
    gap = np.full((size, 6, 3), 255, np.uint8)
    row = np.concatenate([x for p in panels for x in (p, gap)][:-1], axis=1)
    with atomic_path(args.out) as tmp:
        Image.fromarray(row).save(tmp, format="PNG")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
