"""Pictures of textons: segmentation colours + Gaussian ellipses + direction ticks over an image.

Used for training image grids and ``neuraltex overlay``. Ellipses are drawn at the M = 1 level
set (:func:`neuraltex.textons.ellipse_points`); an SVG variant writes them as ``<ellipse>``
elements.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from PIL import Image, ImageDraw
from skimage.color import hsv2rgb
from torch import Tensor

from neuraltex.svg_text import document
from neuraltex.textons import Textons, ellipse_axes, ellipse_points


def palette(n: int, seed: int = 0) -> np.ndarray:
    """n distinct-ish RGB colours (uint8), golden-ratio hues. Shape: (n, 3)."""
    if n == 0:
        return np.zeros((0, 3), np.uint8)
    hues = (np.arange(n) * 0.618033988749895 + seed * 0.1) % 1.0
    hsv = np.stack([hues, np.full(n, 0.65), np.full(n, 0.95)], -1)  # (n, 3)
    rgb = hsv2rgb(hsv.reshape(n, 1, 3), channel_axis=-1).reshape(n, 3)
    return (rgb * 255).astype(np.uint8)


def draw_overlay(image: Tensor, textons: Textons, masks: Tensor | None = None,
                 opacity: float = 0.45, scale: int = 1) -> Image.Image:
    """One picture for one set: image (3, H, W) in [0, 1], textons with batch size 1, optional
    masks (n, h, w). Segments are coloured by argmax query (effective textons only)."""
    img = (image.detach().clamp(0, 1).permute(1, 2, 0).cpu().numpy() * 255).astype(np.uint8)
    H, W = img.shape[:2]
    n = max(textons.num_textons, 0 if masks is None else masks.shape[0])
    colours = palette(n)
    eff = np.zeros(n, dtype=bool)  # queries without a texton are never tinted
    eff[: textons.num_textons] = (textons.delta[0] > 0.5).cpu().numpy()
    if masks is not None:
        from neuraltex.segments import mask_argmax

        label = mask_argmax(masks, (H, W))[0]  # a chunk of masks at a time (bounded memory)
        tint = colours[label].astype(np.float32)
        keep = eff[label][..., None]
        img = np.where(keep, (1 - opacity) * img + opacity * tint, img).astype(np.uint8)
    pic = Image.fromarray(img).resize((W * scale, H * scale), Image.NEAREST)
    draw = ImageDraw.Draw(pic)
    S = min(H, W) * scale
    pts = ellipse_points(textons.mu[0].cpu(), textons.cov[0].cpu()) * S
    for k in np.nonzero(eff)[0]:
        colour = tuple(int(c) for c in colours[k])
        draw.line([tuple(p) for p in pts[k].tolist()], fill=colour, width=max(1, scale))
        cx, cy = (textons.mu[0, k].cpu() * S).tolist()
        a, _, _ = ellipse_axes(textons.cov[0, k].cpu())
        vx, vy = textons.v[0, k].cpu().tolist()
        r = float(a) * S * 0.6
        draw.line([(cx, cy), (cx + vx * r, cy + vy * r)], fill=(255, 255, 255), width=1)
    return pic


def ellipses_svg(textons: Textons, width: int, height: int, level: float = 1.0) -> str:
    """The effective Gaussians of one set as SVG ellipses (pixel units of a width x height
    image), coloured like :func:`draw_overlay`."""
    S = min(width, height)
    colours = palette(textons.num_textons)
    a, b, ang = ellipse_axes(textons.cov[0].cpu(), level)
    parts = []
    for k in torch.nonzero(textons.delta[0] > 0.5).flatten().tolist():
        cx, cy = (textons.mu[0, k].cpu() * S).tolist()
        r, g, bl = (int(c) for c in colours[k])
        parts.append(
            f'<ellipse id="texton-{k}" cx="{cx:.3f}" cy="{cy:.3f}" rx="{float(a[k]) * S:.3f}" '
            f'ry="{float(b[k]) * S:.3f}" transform="rotate({math.degrees(float(ang[k])):.3f} '
            f'{cx:.3f} {cy:.3f})" fill="rgb({r},{g},{bl})" fill-opacity="0.35" '
            f'stroke="rgb({r},{g},{bl})"/>')
    return document(width, height, parts)
