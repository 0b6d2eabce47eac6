"""Reading and writing pictures for the CLIs: any common mode in, RGB float out; atomic writes.
Frame sequences go to an animated GIF, an MP4 (when imageio has a video writer) or numbered
pictures (``out_{i}.png``).

Grayscale, palette, RGBA/LA (composited on white), CMYK and 16-bit images are converted, not
rejected. Corrupt or unreadable files raise :class:`InputError`. Images beyond the picture
budget (:class:`neuraltex.limits.Limits`) are downscaled with a notice instead of running out of
memory; extreme aspect ratios are refused.
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import numpy as np
import torch
from PIL import Image, UnidentifiedImageError

from neuraltex.errors import InputError
from neuraltex.fileio import atomic_path, check_writable
from neuraltex.limits import MAX_SIDE, Limits

WRITE_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".webp": "WEBP"}
MAX_DECODE_PIXELS = 100_000_000  # refuse to even decode beyond this (decompression bombs)


def _to_rgb(im: Image.Image) -> np.ndarray:
    if im.mode in ("I;16", "I;16B", "I;16L", "I"):
        arr = np.asarray(im, dtype=np.float64)
        arr = arr / (65535.0 if arr.max() > 255 else 255.0)
        return np.repeat(arr[..., None], 3, axis=2).astype(np.float32)
    if im.mode == "P":
        im = im.convert("RGBA")
    if im.mode in ("RGBA", "LA", "PA"):
        rgba = im.convert("RGBA")
        white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
        im = Image.alpha_composite(white, rgba)
    return np.asarray(im.convert("RGB"), dtype=np.float32) / 255.0


def load_image(path: str | os.PathLike, max_side: int = MAX_SIDE,
               limits: Limits | None = None) -> torch.Tensor:
    """Read an image as (3, H, W) float32 in [0, 1], downscaled into ``limits`` (default: the
    standard budget with ``max_side``); an extreme aspect ratio is refused."""
    path = Path(path)
    limits = limits or Limits(max_side=max_side)
    if not path.is_file():
        raise InputError(f"{path}: no such image file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            Image.MAX_IMAGE_PIXELS = MAX_DECODE_PIXELS
            with Image.open(path) as im:
                w, h = im.size
                size = limits.input_size(w, h, str(path))  # before decoding any pixel
                im.load()
                if size != (w, h):
                    print(f"note: {path} is {w}x{h}; downscaled to {size[0]}x{size[1]} "
                          f"(--max-side {limits.max_side}, --max-pixels {limits.max_pixels})",
                          file=sys.stderr)
                    im = im.resize(size, Image.Resampling.LANCZOS)
                arr = _to_rgb(im)
    except InputError:
        raise
    except (UnidentifiedImageError, Image.DecompressionBombError,
            Image.DecompressionBombWarning) as exc:
        raise InputError(f"{path}: not a readable image ({exc})") from None
    except (OSError, ValueError, SyntaxError, MemoryError) as exc:
        raise InputError(f"{path}: corrupt or unsupported image ({exc})") from None
    if arr.ndim != 3 or min(arr.shape[:2]) < 1:
        raise InputError(f"{path}: empty image")
    return torch.from_numpy(np.ascontiguousarray(arr.transpose(2, 0, 1)))


def check_output_path(path: str | os.PathLike) -> Path:
    """``path`` when a picture can be written there (known suffix, writable folder)."""
    path = Path(path)
    if path.suffix.lower() not in WRITE_FORMATS:
        raise InputError(f"{path}: output must end in one of {', '.join(WRITE_FORMATS)}")
    return check_writable(path)


def save_image(image: torch.Tensor, path: str | os.PathLike) -> None:
    """Write (3, H, W) in [0, 1] atomically; the format follows the extension."""
    path = check_output_path(path)
    pic = _to_pil(image)
    with atomic_path(path) as tmp:
        pic.save(tmp, format=WRITE_FORMATS[path.suffix.lower()])


def save_pil(pic: Image.Image, path: str | os.PathLike) -> None:
    path = check_output_path(path)
    with atomic_path(path) as tmp:
        pic.convert("RGB").save(tmp, format=WRITE_FORMATS[path.suffix.lower()])


def stack_rows(rows: list[Image.Image], gap: int = 0) -> Image.Image:
    """Pictures one under another on white, ``gap`` pixels apart (for contact sheets)."""
    out = Image.new("RGB", (max(r.width for r in rows), sum(r.height + gap for r in rows)),
                    "white")
    y = 0
    for r in rows:
        out.paste(r, (0, y))
        y += r.height + gap
    return out


def _to_pil(image: torch.Tensor) -> Image.Image:
    arr = (image.detach().float().clamp(0, 1).permute(1, 2, 0).cpu().numpy() * 255).round()
    return Image.fromarray(arr.astype(np.uint8))


def numbered(path: str | os.PathLike, count: int) -> list[Path]:
    """``count`` output paths from a pattern with ``{i}`` (``out_{i}.png``, ``f{i:03d}.jpg``);
    without ``{i}``, one output keeps its name and several get ``_{i}`` before the suffix."""
    path = Path(path)
    pattern = str(path)
    if "{i" not in pattern:
        if count == 1:
            return [check_output_path(path)]
        pattern = str(path.with_name(f"{path.stem}_{{i}}{path.suffix}"))
    try:
        paths = [Path(pattern.format(i=i)) for i in range(count)]
    except (KeyError, IndexError, ValueError) as exc:
        raise InputError(f"{path}: bad output pattern ({exc}); use {{i}} for the number") from None
    for q in paths:
        check_output_path(q)
    return paths


def _mp4_writer_available() -> bool:
    import importlib.util

    if importlib.util.find_spec("imageio") is None:
        return False
    return any(importlib.util.find_spec(m) is not None for m in ("imageio_ffmpeg", "av"))


def check_sequence_output(path: str | os.PathLike) -> Path:
    """Validate where a frame sequence goes (.gif, .mp4, or a picture pattern) before work."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".mp4" and not _mp4_writer_available():
        raise InputError(f"{path}: no MP4 writer installed (pip install imageio[ffmpeg]); "
                         "write a .gif or numbered pictures (out_{i}.png) instead")
    if suffix not in (".gif", ".mp4"):
        numbered(path, 2)
    return path


def save_frames(frames: list[torch.Tensor], path: str | os.PathLike, fps: float = 12) -> list[Path]:
    """Write (3, H, W) frames as an animated GIF, an MP4 or numbered pictures (by the name)."""
    path = check_sequence_output(path)
    suffix = path.suffix.lower()
    if suffix == ".gif":
        pics = [_to_pil(f) for f in frames]
        with atomic_path(path) as tmp:
            pics[0].save(tmp, format="GIF", save_all=True, append_images=pics[1:], loop=0,
                         duration=round(1000 / fps))
        return [path]
    if suffix == ".mp4":
        import imageio.v3 as iio

        arr = np.stack([np.asarray(_to_pil(f)) for f in frames])
        with atomic_path(path) as tmp:
            iio.imwrite(tmp, arr, fps=fps)
        return [path]
    paths = numbered(path, len(frames))
    for frame, q in zip(frames, paths, strict=True):
        save_image(frame, q)
    return paths
