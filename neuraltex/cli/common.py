"""What every ``neuraltex`` subcommand shares: loading the model, reading a texture (an image or
a texton file) into textons, output sizes, decoding, and the argparse pieces.

Helpers take explicit values, never the argparse ``Namespace``. Every command that needs the
model goes through :func:`load`; every command that reads a texture goes through
:func:`textons_of` (or :func:`encode` where it needs the image itself), so a new input kind is
added in one place. Heavy imports happen inside the functions (``--help`` stays fast).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from neuraltex.cli import args as types
from neuraltex.errors import InputError
from neuraltex.limits import MAX_ASPECT, MAX_PIXELS, MAX_SIDE, Limits

if TYPE_CHECKING:
    from torch import Tensor

    from neuraltex.model import Encoded, TextonAutoencoder
    from neuraltex.textons import Textons

IMAGE_OUT = ".png/.jpg/.webp"
TEXTON_FILES = (".json", ".pt")
TEXTURE_FILE = ".ntex"  # a tuned texture (neuraltex fit): textons + its own decoder


def load(checkpoint: str | Path | None, device: str = "cpu",
         seed: int | None = None) -> TextonAutoencoder:
    """The model at ``checkpoint`` (None: the shipped default) on ``device``; ``seed`` seeds
    torch first (texton existence is sampled in some commands)."""
    import torch

    from neuraltex.heap import keep_freed_memory
    from neuraltex.model import DEFAULT_MODEL, load_model
    from neuraltex.nn_utils import flush_subnormals

    problem = types.device_problem(str(device))
    if problem:  # commands whose --device is not parsed by args.device
        raise InputError(f"--device {problem}")
    path = Path(checkpoint) if checkpoint else DEFAULT_MODEL
    if not checkpoint and not path.exists():
        raise InputError("no default model is shipped; pass --checkpoint MODEL.safetensors "
                         "(python -m train writes one)")
    if seed is not None:
        torch.manual_seed(seed)
    flush_subnormals(device)
    keep_freed_memory()  # large tensors reused, not page-faulted in again (neuraltex.heap)
    return load_model(path, device=device)


def limits(args: argparse.Namespace) -> Limits:
    """The picture budget set by --max-side, --max-pixels and --max-aspect."""
    return Limits(args.max_side, args.max_pixels, args.max_aspect)


def encode(model: TextonAutoencoder, path: Path, lim: Limits, device: str = "cpu",
           tile: str = "auto") -> tuple[Tensor, Encoded]:
    """(image (3, H, W) in [0, 1], its encoding) of the image at ``path``, whole or from tiles
    as ``tile`` says (:func:`neuraltex.tiled_encode.encode_image`); images beyond the budget
    ``lim`` are downscaled first."""
    import torch

    from neuraltex.imageio import load_image
    from neuraltex.tiled_encode import encode_image

    image = load_image(path, limits=lim).to(device)
    with torch.no_grad():
        return image, encode_image(model, image[None], tile)


@dataclass
class Texture:
    """One texture read by :func:`textons_of`."""

    textons: Textons  # one set (batch size 1), on the model's device
    short: int  # default output short side: the image's, or 256 for a texton file
    image: Tensor | None = None  # (3, H, W) when read from an image
    masks: Tensor | None = None  # (n, h, w) softmax masks when read from an image
    decoder: TextonAutoencoder | None = None  # the tuned model of a texture file
    labels: object = None  # (H, W) int64 segments of a texture file (numpy)
    elements: object = None  # (K,) int64 element of each texton of a texture file (numpy)
    header: dict | None = None  # a texture file's header (source, size, fit ...)


def textons_of(model: TextonAutoencoder, path: Path, lim: Limits, device: str = "cpu",
               tile: str = "auto") -> Texture:
    """The textons of a texture given as an image (encoded by ``model``, whole or from tiles
    as ``tile`` says), a texton file
    (.json/.pt, checked against the model; it must hold one set) or a texture file (.ntex,
    tuned from ``model`` by ``neuraltex fit``; it brings its own decoder)."""
    import torch

    if path.suffix.lower() == TEXTURE_FILE:
        from neuraltex.texture_file import load_texture
        from neuraltex.tuned_decoder import tuned_model

        tex = load_texture(path, model)
        return Texture(tex.textons.to(device=device), min(tex.header["size"]),
                       decoder=tuned_model(model, tex.generator).to(device), labels=tex.labels,
                       elements=tex.elements, header=tex.header)
    if path.suffix.lower() in TEXTON_FILES:
        from neuraltex.textons_file import load_textons

        t = load_textons(path)
        check_fits(t, model, path)
        if t.batch_size != 1:
            raise InputError(f"{path}: holds {t.batch_size} texton sets; editing takes one")
        return Texture(t.to(device=device, dtype=torch.float32), 256)
    image, enc = encode(model, path, lim, device, tile)
    return Texture(enc.textons, min(image.shape[-2:]), image, enc.masks[0])


def source_picture(path: Path, tex: Texture, texture: Path, lim: Limits) -> Tensor:
    """(3, h, w) the picture the texture file ``texture`` was fitted to, read from ``path``
    and checked against the sha256 of its bytes that the file's header records (a texture
    file does not hold the picture; its pixels make edits as sharp as the photograph)."""
    from neuraltex.fileio import file_sha256
    from neuraltex.imageio import load_image

    if tex.header is None:
        raise InputError(f"--source goes with a texture file (.ntex); {texture} is its own "
                         "source")
    if not path.is_file():
        raise InputError(f"{path}: no such image file")
    want = tex.header.get("source")
    want = want if isinstance(want, dict) else {}
    if file_sha256(path) != want.get("sha256"):
        raise InputError(f"{path}: not the picture {texture.name} was fitted to "
                         f"({want.get('file', 'unknown')}; its sha256 differs)")
    return load_image(path, limits=lim)


def add_source_option(p: argparse.ArgumentParser, what: str, note: str = "") -> None:
    p.add_argument("--source", type=Path, metavar="IMAGE",
                   help="with a texture file: the picture it was fitted to (checked by its "
                   f"sha256); {what} its pixels instead of the reconstruction's{note}")


def check_textons_out(path: Path) -> Path:
    """``path`` when texton files can be written there (.json/.pt, writable folder)."""
    from neuraltex.fileio import check_writable

    if path.suffix not in TEXTON_FILES:
        raise InputError(f"{path}: textons are written as .json or .pt")
    return check_writable(path)


def decoder_for(model: TextonAutoencoder, *textures: Texture,
                t: float | None = None) -> tuple[TextonAutoencoder, list[Textons]]:
    """The model that decodes a combination of ``textures`` (the first texture file's tuned
    decoder, if any) and their textons in its layout (:func:`neuraltex.tuned_decoder.combine`)."""
    from neuraltex.tuned_decoder import combine

    return combine(model, [(tex.textons, tex.decoder) for tex in textures], t)


def check_fits(textons: Textons, model: TextonAutoencoder, source: Path) -> None:
    """InputError unless the textons have the feature channels the model's generator takes
    (and possibly detail sprites after them, :mod:`neuraltex.texton_detail`)."""
    from neuraltex.texton_detail import sprite_side

    plain = model.generator.feature_channels - 2
    try:
        sprite_side(textons.feature_dim - plain)
    except ValueError:
        raise InputError(f"{source}: {textons.feature_dim} feature channels, but the "
                         f"model expects {plain} (+ 3 S^2 for detail sprites)") from None


def output_size(size: list[int] | None, canvas: tuple[float, float], default_short: int,
                lim: Limits | None = None) -> tuple[int, int]:
    """(H, W) from ``--size N`` (short side) or ``--size H W``, else the canvas (w, h) at
    ``default_short``; InputError when the picture is beyond the budget ``lim``."""
    lim = lim or Limits()
    if size and len(size) > 2:
        raise InputError(f"--size takes N (short side) or H W, got {len(size)} numbers")
    if size and len(size) == 2:
        check_covered(size, canvas)
        return lim.check_output(size[0], size[1])
    short = size[0] if size else default_short
    w, h = canvas
    lim.check_output(h, w, "canvas")  # refuses extreme aspect ratios before scaling
    s = short / min(w, h)
    return lim.check_output(max(1, round(h * s)), max(1, round(w * s)))


def check_covered(size: list[int], canvas: tuple[float, float], tol: float = 0.02) -> None:
    """InputError when a picture of ``size`` = (H, W) would show more than the textons'
    ``canvas`` (w, h): the decode window (short side = 1) would reach where no texton is."""
    h, w = size
    s = min(h, w)
    if w / s > canvas[0] * (1 + tol) or h / s > canvas[1] * (1 + tol):
        raise InputError(
            f"--size {h} {w} is a {w / h:.3g}:1 picture, but the textons cover a "
            f"{canvas[0] / canvas[1]:.3g}:1 canvas, so part of it would be painted from "
            "nothing; grow the texture first (neuraltex synthesize TEXTURE --size H W) or "
            "give --size N")


def decode(model: TextonAutoencoder, textons: Textons, size: tuple[int, int],
           device: str = "cpu") -> Tensor:
    """Textons -> images (B, 3, H, W) in [0, 1] at ``size`` = (H, W), without gradients."""
    import torch

    with torch.no_grad():
        return model.decode(textons.to(device=device), size)


def save(image: Tensor, path: Path) -> None:
    """Write an image (3, H, W) and say so."""
    from neuraltex.imageio import save_image

    save_image(image, path)
    print(f"wrote {path} ({image.shape[-1]}x{image.shape[-2]})")


def add_model_options(p: argparse.ArgumentParser, size: bool = True,
                      max_pixels: int = MAX_PIXELS) -> None:
    """--checkpoint, --device, --seed, the picture budget (and --size) of the model commands."""
    p.add_argument("--checkpoint", help="model .safetensors (default: the shipped model)")
    p.add_argument("--device", default="cpu", type=types.device,
                   help="torch device: cpu (default), cuda, cuda:N or mps")
    p.add_argument("--seed", type=types.seed, help=f"random seed in [0, {types.SEED_MAX}]")
    add_limit_options(p, max_pixels)
    if size:
        p.add_argument("--size", type=types.integer(1, 2**16), nargs="+", metavar="N",
                       help="output size: N (short side) or H W; at most --max-pixels pixels")


def add_limit_options(p: argparse.ArgumentParser, max_pixels: int) -> None:
    """--max-side, --max-pixels, --max-aspect: the picture budget (neuraltex.limits)."""
    p.add_argument("--max-side", type=types.integer(1, 2**16), default=MAX_SIDE,
                   help=f"inputs with a longer side are downscaled to it (default {MAX_SIDE})")
    p.add_argument("--max-pixels", type=types.integer(1, 2**28), default=max_pixels,
                   help="inputs with more pixels are downscaled, larger outputs refused "
                   f"(default {max_pixels}, about {max_pixels / 1e6:.1f} MP: <= ~2 GB of memory)")
    p.add_argument("--max-aspect", type=types.number(1, 1e4), default=MAX_ASPECT,
                   help="pictures (in or out) with a longer side more than this many times "
                   f"the shorter are refused (default {MAX_ASPECT:g})")


def model_command(sub, name: str, func, help: str, source: str, output_help: str,
                  size: bool = True, max_pixels: int = MAX_PIXELS) -> argparse.ArgumentParser:
    """A subcommand that reads ``source``, runs the model and writes ``-o OUTPUT``."""
    p = sub.add_parser(name, help=help, description=func.__doc__)
    p.add_argument(source, type=Path, help=f"input {source}")
    p.add_argument("-o", "--output", type=Path, required=True, help=output_help)
    add_model_options(p, size=size, max_pixels=max_pixels)
    if source != "textons":
        add_tile_option(p)
    p.set_defaults(func=func)
    return p


def add_tile_option(p, note: str = "") -> None:
    """--tile: how an input image is encoded (neuraltex.tiled_encode); ``p`` a parser or an
    argument group, ``note`` the start of the help."""
    from neuraltex.tiled_segments import DENSE, TILING

    p.add_argument("--tile", choices=TILING, default="auto",
                   help=f"{note}an input image is encoded whole (off), from overlapping tiles "
                   "seen at twice the scale (on: one texton per element on dense pictures, "
                   f"e.g. a brick wall), or from tiles when the whole picture gives {DENSE} or "
                   "more segments (auto, the default)")
