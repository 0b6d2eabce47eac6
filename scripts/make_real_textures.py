"""Write the real-texture set (data/real_textures/*.png, 256 x 256 RGB) and its source table.

Every picture is a photograph or scan that ships with an installable package; none is
procedural. Two sources:

- scikit-image's bundled sample data (a dependency of this project): CC0 / public-domain photos;
- GIMP's stock patterns (Debian package ``gimp-data``, GPL-3+): seamless photographic tiles,
  read from their ``.pat`` files and tiled to 256 px (so they repeat, without seams).

    apt-get download gimp-data && dpkg -x gimp-data_*.deb /tmp/gimp   # development time only
    python scripts/make_real_textures.py --gimp /tmp/gimp/usr/share/gimp/2.0/patterns

The PNGs are committed, so tests, CI and benchmarks never need the Debian package.
"""

from __future__ import annotations

import argparse
import struct
from pathlib import Path

import numpy as np
from PIL import Image

OUT = Path(__file__).resolve().parents[1] / "data" / "real_textures"
SIZE = 256

# name -> (skimage.data function, crop box (top, left, size) before resizing to SIZE, what)
SKIMAGE = {
    "brick": ("brick", (0, 0, 512), "brick wall (CC0Textures Bricks25), grayscale"),
    "grass": ("grass", (0, 0, 512), "grass (DeviantArt linolafett, CC0), grayscale"),
    "gravel": ("gravel", (0, 0, 512), "gravel (CC0Textures Gravel04), grayscale"),
    "coins": ("coins", (20, 0, 256), "Greek coins from Pompeii (Brooklyn Museum, public "
              "domain), grayscale"),
    "cells_ihc": ("immunohistochemistry", (0, 0, 512), "immunohistochemistry stain of cells "
                  "(public domain, skimage)"),
    "moon": ("moon", (0, 0, 512), "lunar surface craters (public domain, skimage), grayscale"),
    "galaxies": ("hubble_deep_field", (300, 300, 256), "Hubble deep field (NASA, public "
                 "domain)"),
}
SKIMAGE_LICENCE = "CC0 / public domain (scikit-image data/README, docstrings)"

# GIMP pattern file (relative to the patterns folder) -> what it shows
GIMP = {
    "java_beans": ("Food/java.pat", "coffee beans"),
    "leopard": ("Animal/leopard.pat", "leopard fur"),
    "leather": ("Animal/leather.pat", "leather grain"),
    "burlap": ("Fabric/burlap.pat", "woven burlap"),
    "leaves": ("Plant/leaves.pat", "leaves"),
    "stone_wall": ("Stone/stone33.pat", "stone wall"),
    "cracked": ("Stone/cracked.pat", "cracked ground"),
    "craters": ("Stone/Craters.pat", "cratered rock"),
    "rock": ("Stone/rock.pat", "rock"),
    "ground": ("Stone/ground1.pat", "pebbly ground"),
    "granite": ("Stone/granite1.pat", "granite, grayscale"),
    "slate": ("Stone/slate.pat", "slate, grayscale"),
    "burlwood": ("Wood/burlwood.pat", "burl wood"),
    "bricks_gimp": ("Stone/brick.pat", "brick wall"),
    "bark": ("Wood/bark.pat", "tree bark"),
    "corkboard": ("Wood/corkboard.pat", "cork board"),
    "walnut": ("Wood/walnut.pat", "walnut wood"),
    "ice": ("Water/ice.pat", "ice"),
}
GIMP_LICENCE = "GPL-3+ (Debian gimp-data 2.10.34, copyright 'Files: *')"


def read_pat(path: Path) -> np.ndarray:
    """A GIMP ``.pat`` file -> (H, W, 3) uint8. Format: big-endian header (header size,
    version, width, height, bytes per pixel, 'GPAT', name), then raw pixels."""
    data = path.read_bytes()
    header, _, w, h, bpp = struct.unpack(">5I", data[:20])
    if data[20:24] != b"GPAT" or bpp not in (1, 2, 3, 4):
        raise ValueError(f"{path}: not a GIMP pattern")
    px = np.frombuffer(data[header:header + w * h * bpp], np.uint8).reshape(h, w, bpp)
    if bpp <= 2:
        px = np.repeat(px[..., :1], 3, axis=2)
    return np.ascontiguousarray(px[..., :3])


def tile_to(px: np.ndarray, size: int) -> np.ndarray:
    h, w = px.shape[:2]
    reps = (-(-size // h), -(-size // w), 1)
    return np.tile(px, reps)[:size, :size]


def skimage_textures() -> dict[str, np.ndarray]:
    import skimage.data

    out = {}
    for name, (func, (top, left, side), _) in SKIMAGE.items():
        px = getattr(skimage.data, func)()
        px = px[top:top + side, left:left + side]
        if px.ndim == 2:
            px = np.repeat(px[..., None], 3, axis=2)
        im = Image.fromarray(px[..., :3]).resize((SIZE, SIZE), Image.Resampling.LANCZOS)
        out[name] = np.asarray(im)
    return out


def gimp_textures(folder: Path) -> dict[str, np.ndarray]:
    return {name: tile_to(read_pat(folder / rel), SIZE) for name, (rel, _) in GIMP.items()}


def sources_table() -> str:
    rows = ["| file | what | source | licence |", "|---|---|---|---|"]
    for name, (func, box, what) in SKIMAGE.items():
        rows.append(f"| {name}.png | {what} | `skimage.data.{func}()`, crop {box} resized to "
                    f"{SIZE} px | {SKIMAGE_LICENCE} |")
    for name, (rel, what) in GIMP.items():
        rows.append(f"| {name}.png | {what} | GIMP pattern `{rel}`, tiled to {SIZE} px | "
                    f"{GIMP_LICENCE} |")
    return ("# Real textures\n\nPhotographed or scanned textures that ship with installable "
            "packages, written by `scripts/make_real_textures.py`; none is procedural. GIMP's "
            "patterns are small seamless tiles, so those pictures repeat (without seams).\n\n"
            + "\n".join(rows) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--gimp", type=Path, required=True,
                    help="GIMP's patterns folder (…/usr/share/gimp/2.0/patterns)")
    ap.add_argument("--out", type=Path, default=OUT, help=f"output folder (default {OUT})")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    pictures = {**skimage_textures(), **gimp_textures(args.gimp)}
    for name, px in pictures.items():
        Image.fromarray(px).save(args.out / f"{name}.png", optimize=True)
    (args.out / "SOURCES.md").write_text(sources_table())
    print(f"wrote {len(pictures)} textures and SOURCES.md to {args.out}")


if __name__ == "__main__":
    main()
