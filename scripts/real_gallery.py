"""Editing gallery on real textures with texture files, for the README.

    python scripts/real_gallery.py                       # 4 real textures, 55 s fit each
    python scripts/real_gallery.py --seconds 10 --out /tmp/g

Each texture of data/real_textures is tuned (``neuraltex fit``), then one row shows:
input | reconstruction | 2 reshuffles (by elements) | transfer (this texture's structure in the
next texture's palette, ``neuraltex transfer A.ntex B.ntex``) | interpolation with the next
texture (t = 0.5, ``neuraltex interpolate A.ntex B.ntex``) | vary (appearance 0.3). Writes
``real_gallery.png`` and ``real_animate.gif`` (vortex flow on the first texture).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from make_gallery import strip  # noqa: E402

from neuraltex.edit.animation import animate  # noqa: E402
from neuraltex.edit.palette import palette_blend, palette_transfer  # noqa: E402
from neuraltex.edit.vary import vary  # noqa: E402
from neuraltex.element_swap import swap_elements  # noqa: E402
from neuraltex.fit import FitSettings, fit_texture  # noqa: E402
from neuraltex.imageio import load_image, save_frames, save_pil, stack_rows  # noqa: E402
from neuraltex.model import DEFAULT_MODEL, load_model  # noqa: E402
from neuraltex.tuned_decoder import COLOUR, tuned_model  # noqa: E402

REAL = Path(__file__).resolve().parents[1] / "data" / "real_textures"
DOCS = Path(__file__).resolve().parents[1] / "docs"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("names", nargs="*", default=["brick", "coins", "leopard", "stone_wall"],
                    help="real textures (file stems in data/real_textures)")
    ap.add_argument("--seconds", type=float, default=55.0,
                    help="whole-fit budget per texture (55, the CLI default)")
    ap.add_argument("--steps", type=int, help="fit step budget instead (reproducible)")
    ap.add_argument("--out", type=Path, default=DOCS, help="output folder (default docs/)")
    args = ap.parse_args()
    torch.set_num_threads(1)
    model = load_model(DEFAULT_MODEL)
    fits = []
    for name in args.names:
        image = load_image(REAL / f"{name}.png")
        fit = fit_texture(model, image, FitSettings(seconds=None if args.steps else args.seconds,
                                                    steps=args.steps))
        print(f"{name}: {fit.segmenter}, {fit.textons.num_textons} textons, "
              f"{fit.steps} steps, PSNR {fit.base_psnr:.2f} -> {fit.plain_psnr:.2f} dB, "
              f"with detail sprites {fit.psnr:.2f} dB", flush=True)
        fits.append((name, image, fit.textons, tuned_model(model, fit.generator),
                     (fit.labels, fit.elements)))
    rows = []
    for i, (name, image, t, dec, groups) in enumerate(fits):
        other_name, _, u, other, (other_labels, _) = fits[(i + 1) % len(fits)]
        rows.append(strip(row(name, image, t, dec, groups, other_name, u, other,
                              other_labels)))
    args.out.mkdir(parents=True, exist_ok=True)
    save_pil(stack_rows(rows), args.out / "real_gallery.png")
    name, image, t, dec, _ = fits[0]
    frames = animate(t, "vortex", 24, 4.0, 0, 0.5, 2 * torch.pi / 4)
    with torch.no_grad():
        pics = [dec.decode(f, tuple(image.shape[-2:]))[0] for f in frames]
    save_frames(pics, args.out / "real_animate.gif", 12)
    print(f"wrote {args.out / 'real_gallery.png'} and {args.out / 'real_animate.gif'}")


@torch.no_grad()
def row(name, image, t, dec, groups, other_name, u, other, other_labels) -> list:
    """One gallery row of texture ``name`` (its textons t, tuned decoder dec, (labels,
    elements) groups), with the next texture (textons u, decoder other) as the second."""
    size = tuple(image.shape[-2:])
    plain = dec.generator.feature_channels - 2  # [f_a, d]; detail sprites after
    rec = dec.decode(t, size)
    rec_other = other.decode(u, size)[0]
    labels = groups[0]
    tiles = [(name, image), ("fit reconstruction", rec)]
    for seed in (1, 2):
        tiles.append((f"reshuffle {seed}", swap_elements(rec[0], *groups, seed=seed)[None]))
    tiles.append((f"{other_name} palette", palette_transfer(rec[0], labels, rec_other,
                                                             other_labels)[None]))
    tiles.append((f"<-> {other_name} 0.5", palette_blend(rec[0], labels, rec_other,
                                                         other_labels, 0.5)[None]))
    tiles.append(("vary 0.3", dec.decode(vary(t, 0.3, 1.0, keep=plain - COLOUR), size)))
    return tiles


if __name__ == "__main__":
    main()
