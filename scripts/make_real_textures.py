"""Write the real-texture set (data/real_textures/*.png, 256 x 256 RGB) and its source table.

Every picture is a photograph or scan that ships with an installable package; none is
procedural. Two sources:

- scikit-image's bundled sample data (a dependency of this project): CC0 / public-domain photos;
- GIMP's stock patterns (Debian package ``gimp-data``, GPL-3+): seamless photographic tiles,
  read from their ``.pat`` files and tiled to 256 px (so they repeat, without seams).

    apt-get download gimp-data && dpkg -x gimp-data_*.deb /tmp/gimp   # development time only
    python scripts/make_real_textures.py --gimp /tmp/gimp/usr/share/gimp/2.0/patterns

The PNGs are committed, so tests, CI and benchmarks never need the Debian package.

A second, **held-out** set (data/real_textures_heldout: more of GIMP's photographic patterns)
was added after every default of the project had been chosen on the first one: no setting was
tuned on it, so its numbers say how the tools do on textures nobody looked at while building
them. ``--heldout`` writes it.
"""

from __future__ import annotations

import argparse
import struct
from pathlib import Path

import numpy as np
from PIL import Image

OUT = Path(__file__).resolve().parents[1] / "data" / "real_textures"
HELDOUT_OUT = OUT.parent / "real_textures_heldout"
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
# the held-out set: GIMP's other photographic patterns (its rendered or drawn ones, e.g.
# choc_swirl, rain, terra, pine and the Legacy folder, are left out)
HELDOUT = {
    "crinklepaper": ("Paper/crinklepaper.pat", "crinkled paper"),
    "paper": ("Paper/paper.pat", "paper fibres, grayscale"),
    "starfield": ("Sky/starfield.pat", "star field with nebulae"),
    "moonfoot": ("Stone/Moonfoot.pat", "footprints in lunar soil (Apollo photograph), grayscale"),
    "amethyst": ("Stone/amethyst.pat", "amethyst tiles"),
    "marble1": ("Stone/marble1.pat", "white marble"),
    "marble2": ("Stone/marble2.pat", "marble tiles with grout lines"),
    "pink_marble": ("Stone/pink_marble.pat", "pink veined marble"),
    "parque1": ("Wood/parque1.pat", "basket-weave parquet"),
    "sky": ("Sky/sky.pat", "clouds in a blue sky"),
    "pool": ("Water/pool.pat", "water surface"),
    "wood1": ("Wood/wood1.pat", "wood grain"),
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


def gimp_textures(folder: Path, table: dict[str, tuple[str, str]] = GIMP
                  ) -> dict[str, np.ndarray]:
    return {name: tile_to(read_pat(folder / rel), SIZE) for name, (rel, _) in table.items()}


def sources_table(heldout: bool = False) -> str:
    rows = ["| file | what | source | licence |", "|---|---|---|---|"]
    for name, (func, box, what) in ({} if heldout else SKIMAGE).items():
        rows.append(f"| {name}.png | {what} | `skimage.data.{func}()`, crop {box} resized to "
                    f"{SIZE} px | {SKIMAGE_LICENCE} |")
    for name, (rel, what) in (HELDOUT if heldout else GIMP).items():
        rows.append(f"| {name}.png | {what} | GIMP pattern `{rel}`, tiled to {SIZE} px | "
                    f"{GIMP_LICENCE} |")
    head = ("# Real textures, held out\n\nAdded after the project's defaults were chosen on "
            "data/real_textures; nothing was tuned on these. " if heldout else
            "# Real textures\n\n")
    return (head + "Photographed or scanned textures that ship with installable "
            "packages, written by `scripts/make_real_textures.py"
            + (" --heldout" if heldout else "") + "`; none is procedural. GIMP's "
            "patterns are small seamless tiles, so those pictures repeat (without seams).\n\n"
            + "\n".join(rows) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--gimp", type=Path, required=True,
                    help="GIMP's patterns folder (…/usr/share/gimp/2.0/patterns)")
    ap.add_argument("--heldout", action="store_true",
                    help=f"write the held-out set instead (default folder {HELDOUT_OUT})")
    ap.add_argument("--out", type=Path, default=None,
                    help=f"output folder (default {OUT}, or {HELDOUT_OUT} with --heldout)")
    args = ap.parse_args()
    out = args.out or (HELDOUT_OUT if args.heldout else OUT)
    out.mkdir(parents=True, exist_ok=True)
    pictures = (gimp_textures(args.gimp, HELDOUT) if args.heldout else
                {**skimage_textures(), **gimp_textures(args.gimp)})
    for name, px in pictures.items():
        Image.fromarray(px).save(out / f"{name}.png", optimize=True)
    (out / "SOURCES.md").write_text(sources_table(args.heldout))
    print(f"wrote {len(pictures)} textures and SOURCES.md to {out}")


if __name__ == "__main__":
    main()
