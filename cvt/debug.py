"""Debug pictures: samples colored by cluster, and the energy curve (PIL only)."""

from __future__ import annotations

import colorsys
from pathlib import Path

import torch
from PIL import Image, ImageDraw

from neuraltex.fileio import atomic_path


def cluster_color(c: int) -> tuple[int, int, int]:
    h = (c * 0.618033988749895) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, 0.75, 0.9)
    return int(r * 255), int(g * 255), int(b * 255)


def draw_samples(pos: torch.Tensor, cluster: torch.Tensor, box, path: str | Path,
                 max_side: int = 800, dot: float = 2.5) -> None:
    """Save a PNG of samples (N, 2) colored by cluster (N,) inside box (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = box
    s = max_side / max(x1 - x0, y1 - y0)
    w, h = max(1, round((x1 - x0) * s)), max(1, round((y1 - y0) * s))
    img = Image.new("RGB", (w, h), "white")
    d = ImageDraw.Draw(img)
    for (x, y), c in zip(pos.tolist(), cluster.tolist(), strict=True):
        px, py = (x - x0) * s, (y - y0) * s
        d.ellipse([px - dot, py - dot, px + dot, py + dot], fill=cluster_color(c))
    with atomic_path(path) as tmp:
        img.save(tmp)


def draw_energy(energies: list[tuple[int, int, float]], path: str | Path,
                size: tuple[int, int] = (640, 320)) -> None:
    """Save a PNG line plot of energy per iteration; level changes are gray lines."""
    w, h = size
    img = Image.new("RGB", size, "white")
    d = ImageDraw.Draw(img)
    if energies:
        vals = [e for _, _, e in energies]
        lo, hi = min(vals), max(vals)
        span = hi - lo or 1.0
        m = 30
        xs = [m + k * (w - 2 * m) / max(1, len(vals) - 1) for k in range(len(vals))]
        ys = [h - m - (v - lo) / span * (h - 2 * m) for v in vals]
        for k in range(1, len(energies)):
            if energies[k][0] != energies[k - 1][0]:
                d.line([(xs[k], m), (xs[k], h - m)], fill=(200, 200, 200))
        d.line(list(zip(xs, ys, strict=True)), fill=(30, 90, 200), width=2)
        d.text((m, 5), f"energy {hi:.3f} .. {lo:.3f}", fill="black")
    with atomic_path(path) as tmp:
        img.save(tmp)
