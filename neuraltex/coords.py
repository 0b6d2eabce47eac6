"""The resolution-independent coordinate convention shared by textons, estimation and splatting.

Texton positions live in *normalized image coordinates*:

- origin at the top-left corner of the image, x to the right, y down;
- one unit is the image's **short side** ``S = min(H, W)``, so the axes are isotropic and a
  Gaussian keeps its shape whatever the aspect ratio: an H x W image covers
  ``[0, W/S] x [0, H/S]`` (a square image covers the unit square);
- pixel (row i, column j) is the box ``[j/S, (j+1)/S] x [i/S, (i+1)/S]``; its centre is
  ``((j + 0.5)/S, (i + 0.5)/S)``.

Rendering the same textons at 2x the pixel size gives the same picture, 2x sharper. A *window*
``(x0, y0, x1, y1)`` selects which part of the plane a raster covers (for patches, tiles, or a
canvas larger than the one the textons came from).
"""

from __future__ import annotations

import torch
from torch import Tensor

Window = tuple[float, float, float, float]


def default_window(height: int, width: int) -> Window:
    """The window an H x W image covers under the convention: ``(0, 0, W/S, H/S)``."""
    if height <= 0 or width <= 0:
        raise ValueError(f"image size must be positive, got {height}x{width}")
    s = float(min(height, width))
    return (0.0, 0.0, width / s, height / s)


def pixel_axes(height: int, width: int, window: Window | None = None, *,
               device=None, dtype=torch.float32) -> tuple[Tensor, Tensor]:
    """Pixel-centre coordinates along each axis of an H x W raster covering ``window``.

    Shape: returns ``xs`` (W,) and ``ys`` (H,).
    """
    x0, y0, x1, y1 = default_window(height, width) if window is None else window
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"window must have x1 > x0 and y1 > y0, got {window}")
    xs = x0 + (torch.arange(width, device=device, dtype=dtype) + 0.5) * ((x1 - x0) / width)
    ys = y0 + (torch.arange(height, device=device, dtype=dtype) + 0.5) * ((y1 - y0) / height)
    return xs, ys


def pixel_grid(height: int, width: int, window: Window | None = None, *,
               device=None, dtype=torch.float32) -> Tensor:
    """Pixel-centre coordinates of an H x W raster, flattened row-major.

    Shape: (H*W, 2) with columns (x, y).
    """
    xs, ys = pixel_axes(height, width, window, device=device, dtype=dtype)
    gy, gx = torch.meshgrid(ys, xs, indexing="ij")  # (H, W) each
    return torch.stack([gx.reshape(-1), gy.reshape(-1)], dim=-1)
