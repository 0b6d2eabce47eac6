"""Pictures of textons: segmentation colours + Gaussian ellipses + direction ticks over an image.

Used for training image grids and ``neuraltex overlay``. Ellipses are drawn at the M = 1 level
set (:func:`ellipse_points`); an SVG variant writes them as ``<ellipse>`` elements.
"""

from __future__ import annotations

import colorsys
import math

import numpy as np
import torch
from PIL import Image, ImageDraw
from torch import Tensor

from neuraltex.textons import Textons


def palette(n: int, seed: int = 0) -> np.ndarray:
    """n distinct-ish RGB colours (uint8), golden-ratio hues. Shape: (n, 3)."""
    hues = (np.arange(n) * 0.618033988749895 + seed * 0.1) % 1.0
    rgb = np.array([colorsys.hsv_to_rgb(h, 0.65, 0.95) for h in hues]).reshape(n, 3)
    return (rgb * 255).astype(np.uint8)


def ellipse_axes(cov: Tensor, level: float = 1.0) -> tuple[Tensor, Tensor, Tensor]:
    """Semi-axes (a >= b) and angle (radians, of a, from +x towards +y) of the M = level ellipse.

    With o = exp(-M^2) (eq. 4.12), M^2 = x^T U^-1 x = level^2 has semi-axes level*sqrt(eig).
    """
    evals, evecs = torch.linalg.eigh(cov.double())
    a = level * evals[..., 1].clamp_min(0).sqrt()
    b = level * evals[..., 0].clamp_min(0).sqrt()
    angle = torch.atan2(evecs[..., 1, 1], evecs[..., 0, 1])
    return a.float(), b.float(), angle.float()


def ellipse_points(mu: Tensor, cov: Tensor, level: float = 1.0, n: int = 32) -> Tensor:
    """Polyline of the ellipse, (..., n, 2)."""
    a, b, ang = ellipse_axes(cov, level)
    th = torch.linspace(0, 2 * math.pi, n)
    x = a[..., None] * torch.cos(th)
    y = b[..., None] * torch.sin(th)
    c, s = torch.cos(ang)[..., None], torch.sin(ang)[..., None]
    return torch.stack([mu[..., 0:1] + c * x - s * y, mu[..., 1:2] + s * x + c * y], -1)


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
        m = torch.nn.functional.interpolate(masks[None].float(), size=(H, W), mode="bilinear",
                                            align_corners=False)[0]
        label = m.argmax(0).cpu().numpy()
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
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             f'viewBox="0 0 {width} {height}">']
    for k in torch.nonzero(textons.delta[0] > 0.5).flatten().tolist():
        cx, cy = (textons.mu[0, k].cpu() * S).tolist()
        r, g, bl = (int(c) for c in colours[k])
        parts.append(
            f'<ellipse id="texton-{k}" cx="{cx:.3f}" cy="{cy:.3f}" rx="{float(a[k]) * S:.3f}" '
            f'ry="{float(b[k]) * S:.3f}" transform="rotate({math.degrees(float(ang[k])):.3f} '
            f'{cx:.3f} {cy:.3f})" fill="rgb({r},{g},{bl})" fill-opacity="0.35" '
            f'stroke="rgb({r},{g},{bl})"/>')
    parts.append("</svg>")
    return "\n".join(parts) + "\n"
