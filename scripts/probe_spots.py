"""Whether each method puts a segment on each spot of data/real_textures/leopard.png
(MODEL.md, "Textons per visible element"): a count of segments (scripts/eval_counts.py) can be
right while the segments cross the elements, so this counts the spots that get a segment of
their own (IoU >= 0.5 with the segment covering most of the spot; scripts/probe_bricks.py's
rule).

The spots are the regions counts.csv counts: the dark 4-connected regions (grey level under 80
of 255) of the GIMP leopard pattern, less the slivers its border cuts (border regions under
half the median area). Felzenszwalb and k-means see the contrast the regions come from, so
they are a ceiling, not a rival; ``fit elements`` are the texture file's elements
(neuraltex.texton_elements, fitted as scripts/eval_counts.py does).

    python scripts/probe_spots.py --cache /tmp/eval_synthesis
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

DARK = 80 / 255  # the spots' grey level bound


def spots(grey: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """(labels (H, W): 0 the fur, k spot k; the spots counted) of a grey picture in [0, 1]:
    dark 4-connected regions, less border regions under half the median region area."""
    from scipy import ndimage as ndi

    labels, n = ndi.label(grey < DARK)
    area = np.bincount(labels.ravel())[1:]
    box = ndi.find_objects(labels)
    h, w = grey.shape
    border = np.array([b[0].start == 0 or b[1].start == 0 or b[0].stop == h or b[1].stop == w
                       for b in box], bool)
    sliver = border & (area < 0.5 * np.median(area))
    return labels, [k + 1 for k in range(n) if not sliver[k]]


def main(argv: list[str] | None = None) -> int:
    from eval_counts import fitted
    from eval_synthesis import add_texture_options, texture_file
    from probe_bricks import own_segments

    from neuraltex.baselines import get_segmenter
    from neuraltex.cli import common
    from neuraltex.imageio import load_image

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_texture_options(p)
    p.add_argument("--image", default="leopard.png",
                   help="a picture of dark spots on a lighter ground, in --textures")
    p.add_argument("--checkpoint", default=None, help="E_s export (default: the shipped model)")
    args = p.parse_args(argv)
    picture = load_image(args.textures / args.image).permute(1, 2, 0).numpy().astype(np.float64)
    # the 0-255 grey level of counts.csv: the mean of the 8-bit channels
    labels, ids = spots(np.round(picture * 255).mean(2) / 255)
    methods = {"E_s, whole": get_segmenter("model", checkpoint=args.checkpoint),
               "E_s, tile auto": get_segmenter("model", checkpoint=args.checkpoint, tile="auto"),
               "felzenszwalb": get_segmenter("felzenszwalb"), "kmeans": get_segmenter("kmeans")}
    found = {m: own_segments(seg(picture), labels, ids) for m, seg in methods.items()}
    ntex = texture_file(args.textures / args.image, args.cache, args.steps)
    elements = fitted(common.load(None), ntex)[2]
    if elements is not None:
        found["fit elements"] = own_segments(elements, labels, ids)
    print(f"Spots with a segment of their own (IoU >= 0.5), {args.image}: {len(ids)} spots")
    print("| picture | spots | " + " | ".join(found) + " |\n|---|---:|" + "---:|" * len(found))
    print(f"| {Path(args.image).stem} | {len(ids)} | " + " | ".join(
        f"{n} ({100 * n / len(ids):.0f} %)" for n in found.values()) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
