"""Export samples to disk (images, masks, metadata) and draw a contact sheet.

Masks are 16-bit grayscale PNGs holding the instance ids (0 = background).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from neuraltex.data.generator import Sample
from neuraltex.fileio import atomic_path


def overlay(image: np.ndarray, mask: np.ndarray, opacity: float = 0.45) -> np.ndarray:
    """Image with each texton tinted a random colour and texton boundaries drawn white.

    Shape: (H, W, 3) float, (H, W) int -> (H, W, 3) float32.
    """
    rng = np.random.default_rng(12345)
    colors = rng.uniform(0.1, 1.0, size=(int(mask.max()) + 1, 3)).astype(np.float32)
    tint = colors[mask]
    a = np.where(mask > 0, opacity, 0.0)[..., None]
    out = image * (1 - a) + tint * a
    edge = np.zeros(mask.shape, bool)
    edge[:, 1:] |= mask[:, 1:] != mask[:, :-1]
    edge[1:, :] |= mask[1:, :] != mask[:-1, :]
    out[edge] = 1.0
    return out.astype(np.float32)


def to_uint8(image: np.ndarray) -> np.ndarray:
    return (np.clip(image, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def contact_sheet(samples: list[Sample], columns: int = 4, label: bool = True) -> Image.Image:
    """A grid of (image | overlay) pairs, labelled with family and texton count."""
    if not samples:
        raise ValueError("contact_sheet needs at least one sample")
    h, w = samples[0].mask.shape
    pad, text_h = 4, 12 if label else 0
    rows = (len(samples) + columns - 1) // columns
    sheet = Image.new("RGB", (columns * (2 * w + 3 * pad), rows * (h + text_h + 2 * pad)), "white")
    draw = ImageDraw.Draw(sheet)
    for n, s in enumerate(samples):
        x0 = (n % columns) * (2 * w + 3 * pad) + pad
        y0 = (n // columns) * (h + text_h + 2 * pad) + pad
        sheet.paste(Image.fromarray(to_uint8(s.image)), (x0, y0 + text_h))
        tinted = Image.fromarray(to_uint8(overlay(s.image, s.mask)))
        sheet.paste(tinted, (x0 + w + pad, y0 + text_h))
        if label:
            tag = "hard" if s.hard else "easy"
            draw.text((x0, y0), f"{s.family} ({tag}) K={s.count}", fill=(0, 0, 0))
    return sheet


def write_sample(out: Path, name: str, sample: Sample) -> dict:
    """Write ``images/NAME.png`` and ``masks/NAME.png``; return the metadata row."""
    with atomic_path(out / "images" / f"{name}.png") as tmp:
        Image.fromarray(to_uint8(sample.image)).save(tmp)
    if sample.count > 65535:
        raise ValueError(f"{sample.count} textons do not fit a 16-bit mask")
    with atomic_path(out / "masks" / f"{name}.png") as tmp:
        Image.fromarray(sample.mask.astype(np.uint16)).save(tmp)
    return dict(name=name, **sample.meta())


def read_mask(path: str | Path) -> np.ndarray:
    """Read a mask written by :func:`write_sample`. Returns (H, W) int32."""
    return np.asarray(Image.open(path)).astype(np.int32)
