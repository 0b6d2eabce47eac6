"""TensorBoard scalars and image grids (when tensorboard is installed), plus PNG copies people
can open without TensorBoard."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch
from PIL import Image

from neuraltex.fileio import atomic_path
from neuraltex.overlay import draw_overlay


class Logger:
    def __init__(self, run_dir: Path, enabled: bool = True, backbone: str = "random") -> None:
        self.enabled, self.run_dir, self.backbone = enabled, Path(run_dir), backbone
        self.writer = None
        if enabled:
            self.run_dir.mkdir(parents=True, exist_ok=True)
            self.writer = _tensorboard(self.run_dir / "tb")
            if self.writer is not None:
                self.writer.add_text("lpips_backbone", backbone)

    def scalars(self, step: int, values: dict[str, float]) -> None:
        if self.writer is None:
            return
        for k, v in values.items():
            self.writer.add_scalar(k if "/" in k else f"loss/{k}", v, step)
        self.writer.flush()

    def images(self, step: int, images: torch.Tensor, out, rows: int = 4) -> None:
        """input | reconstruction | reshuffled | segmentation overlay with Gaussian ellipses."""
        if not self.enabled:
            return
        grid = grid_picture(images, out, rows)
        if self.writer is not None:
            self.writer.add_image("grid", torch.from_numpy(grid).permute(2, 0, 1), step)
        path = self.run_dir / "images" / f"step_{step:07d}.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            Image.fromarray(grid).save(tmp, format="PNG")

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()


def _tensorboard(folder: Path):
    """A TensorBoard writer, or None (with one note) when tensorboard is not installed: it is
    an optional extra (pip install "neuraltex[tensorboard]"); the PNG grids are written anyway."""
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:
        print("note: tensorboard is not installed; no scalar logs (pip install tensorboard)",
              file=sys.stderr)
        return None
    return SummaryWriter(str(folder))


def _u8(x: torch.Tensor) -> np.ndarray:
    return (x.detach().float().clamp(0, 1).permute(1, 2, 0).cpu().numpy() * 255).astype(np.uint8)


def grid_picture(images: torch.Tensor, out, rows: int = 4) -> np.ndarray:
    enc = out.encoded
    lines = []
    for b in range(min(rows, images.shape[0])):
        cells = [_u8(images[b]), _u8(out.recon[b])]
        if out.reshuffled is not None and b < out.reshuffled.shape[0]:
            cells.append(_u8(out.reshuffled[b]))
        else:
            cells.append(np.zeros_like(cells[0]))
        pic = draw_overlay(images[b].float(), enc.textons[b].detach().to(dtype=torch.float32),
                           enc.masks[b].detach())
        cells.append(np.asarray(pic.resize(cells[0].shape[1::-1])))
        lines.append(np.concatenate(cells, axis=1))
    return np.concatenate(lines, axis=0)
