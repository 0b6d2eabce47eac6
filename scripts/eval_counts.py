"""Textons per visible element on hand-counted real textures (issue 16's real-texture target:
one texton per element).

For each texture of data/real_textures/counts.csv (the hand count and how it was made): how
many segments or textons each method gives, and that number over the hand count.

- ``E_s shipped, whole`` / ``E_s CHECKPOINT``: the learned segmenter's effective textons
  (masks of queries with p > 0.5 covering at least ``MIN_SHARE`` of the picture) of the whole
  picture, the shipped model and optionally another export (``--checkpoint``, e.g. the long
  E_s run);
- ``E_s shipped, tile auto``: the shipped model's textons as the commands encode a picture by
  default (from tiles where it is dense, neuraltex.tiled_encode);
- ``fit textons`` / ``fit elements``: a texture file's effective textons, and its elements
  (neuraltex.texton_elements: textons grouped into objects) other than background ones;
- ``felzenszwalb`` / ``kmeans``: the classical segmenters at their tuned defaults
  (docs/baselines.md), segments of at least ``MIN_SHARE``.

    python scripts/eval_counts.py --cache /tmp/eval_synthesis \
        --checkpoint runs/long_segmenter/model.safetensors
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

MIN_SHARE = 0.001  # smallest segment counted, share of the picture's pixels


def segments(labels: np.ndarray, skip_zero: bool) -> int:
    """Segments of ``labels`` (H, W) with at least MIN_SHARE of the pixels (label 0 left out
    when it means "no texton")."""
    ids, area = np.unique(labels, return_counts=True)
    keep = area >= MIN_SHARE * labels.size
    if skip_zero:
        keep &= ids != 0
    return int(keep.sum())


def fitted(model, path: Path) -> tuple[int, int, np.ndarray | None]:
    """(effective textons, non-background elements, the element of each pixel (H, W): 1 + its
    index, 0 for background elements; None for a file without elements) of a texture file."""
    from neuraltex.texton_elements import element_shapes
    from neuraltex.texture_file import load_texture

    tex = load_texture(path, model)
    textons = int((tex.textons.delta[0] > 0.5).sum())
    if tex.elements is None or tex.labels is None:
        return textons, -1, None
    shapes = element_shapes(tex.labels, tex.elements)
    pixels = tex.elements[tex.labels]  # (H, W)
    pixels = np.where(shapes.background[pixels], 0, pixels + 1)
    return textons, int((~shapes.background & (shapes.area > 0)).sum()), pixels


def main() -> None:
    from eval_synthesis import add_texture_options, texture_file

    from neuraltex.baselines import get_segmenter
    from neuraltex.cli import common
    from neuraltex.imageio import load_image
    from neuraltex.tiled_segments import TILING

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_texture_options(p)
    p.add_argument("--checkpoint", type=Path, help="another E_s export to count beside the "
                   "shipped model's")
    p.add_argument("--tile", choices=TILING, default="auto",
                   help="also count E_s's textons from tiles: as the commands encode by default "
                   "(auto: tiles for dense pictures), always (on), or not (off); "
                   "neuraltex/tiled_encode.py")
    p.add_argument("--pictures", type=Path, help="also write a PNG of what is counted: a row "
                   "per texture, the picture then each segmenter's segments in colour")
    args = p.parse_args()
    with open(args.textures / "counts.csv", newline="") as f:
        counts = [(r["file"], int(r["elements"])) for r in csv.DictReader(f)]
    model = common.load(None)
    methods = {"E_s shipped, whole": (get_segmenter("model"), True)}
    if args.tile != "off":
        methods[f"E_s shipped, tile {args.tile}"] = (get_segmenter("model", tile=args.tile), True)
    if args.checkpoint:
        methods[f"E_s {args.checkpoint.parent.name or args.checkpoint.stem}"] = (
            get_segmenter("model", checkpoint=str(args.checkpoint)), True)
    methods |= {name: (get_segmenter(name), False) for name in ("felzenszwalb", "kmeans")}
    head = ["texture", "hand count", *methods, "fit textons", "fit elements"]
    print("| " + " | ".join(head) + " |\n|" + "---|" * len(head))
    ratios: dict[str, list[float]] = {h: [] for h in head[2:]}
    rows = []
    for name, hand in counts:
        image = load_image(args.textures / name)
        arr = image.permute(1, 2, 0).numpy().astype(np.float64)
        labels = {m: seg(arr) for m, (seg, _) in methods.items()}
        found = {m: segments(labels[m], skip) for m, (_, skip) in methods.items()}
        ntex = texture_file(args.textures / name, args.cache, args.steps)
        found["fit textons"], found["fit elements"], elements = fitted(model, ntex)
        if elements is not None and elements.shape == arr.shape[:2]:
            labels["fit elements"] = elements
        rows.append(picture_row(arr, labels, {**methods, "fit elements": (None, True)}))
        for m, n in found.items():
            ratios[m].append(n / hand)
        print(f"| {Path(name).stem} | {hand} | "
              + " | ".join(f"{n} ({n / hand:.2f}x)" for n in found.values()) + " |", flush=True)
    print(summary(ratios))
    if args.pictures:
        from PIL import Image

        from neuraltex.imageio import save_pil, stack_rows

        save_pil(stack_rows([Image.fromarray(r) for r in rows], gap=4), args.pictures)
        print(f"wrote {args.pictures}: a row per texture; picture | "
              + " | ".join(methods) + " | fit elements (grey: E_s's pixels of no texton, "
              "the background elements of the texture file)")


def summary(ratios: dict[str, list[float]]) -> str:
    """Two table rows over the textures, per method: the mean of found / hand-counted, and the
    mean count error |found / hand - 1| (a method that finds too few on one texture and too
    many on another is not right on average)."""
    rows = [("mean per element", lambda r: f"{np.mean(r):.2f}x"),
            ("mean count error", lambda r: f"{100 * np.mean(np.abs(np.subtract(r, 1))):.0f} %")]
    return "\n".join(f"| **{name}** | | " + " | ".join(cell(r) for r in ratios.values()) + " |"
                     for name, cell in rows)


def picture_row(image: np.ndarray, labels: dict[str, np.ndarray], methods) -> np.ndarray:
    """(H, W * (1 + methods), 3) uint8: the picture, then each method's segments coloured over
    its grey (E_s's label 0, pixels of no texton, stays grey)."""
    from skimage.color import label2rgb

    grey = image.mean(2)
    tiles = [image] + [label2rgb(labels[m], image=grey, alpha=0.55,
                                 bg_label=0 if skip else -1, bg_color=None)
                       if m in labels else np.ones_like(image)  # (white: none to show)
                       for m, (_, skip) in methods.items()]
    return (np.concatenate(tiles, axis=1).clip(0, 1) * 255).astype(np.uint8)


if __name__ == "__main__":
    main()
