"""Why E_s misses the bricks of data/real_textures/brick.png (MODEL.md, "Textons per visible
element"): the share of bricks that get a segment of their own (IoU >= 0.5 with the segment
covering most of the brick), for E_s and the classical segmenters, on the photograph and on
pictures that keep one of its properties at a time.

The photograph's bricks are the dark regions between its light mortar (Otsu threshold of the
grey picture, 1 px opening, 4-connected; regions under half the median brick area are edge
slivers and left out), the regions data/real_textures/counts.csv counts. Its quarters keep
its look with a quarter of the bricks each. The same regions drawn flat (bricks 0.35, mortar
0.7, a little noise) keep the layout and drop the photograph's look; drawn with a colour per
brick they look like the procedural ``bricks`` family's colouring. The procedural family's
own bricks (running bond, short, horizontal), drawn grey and flat the same way, keep that
look with the training layout. ``E_s, tile auto`` is the patch-wise encoding of
:mod:`neuraltex.tiled_encode`, as the commands encode by default. Felzenszwalb and k-means
see the threshold the regions come from, so on the photograph they are a ceiling, not a
rival.

    python scripts/probe_bricks.py
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BRICK, MORTAR, NOISE = 0.35, 0.7, 0.04


def photo_bricks(grey: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """(labels (H, W): 0 mortar, k brick k; the bricks counted: at least half the median
    brick area) of a grey picture in [0, 1] whose bricks are darker than their joints."""
    from skimage import filters, measure, morphology

    dark = morphology.opening(grey < filters.threshold_otsu(grey), morphology.disk(1))
    labels = measure.label(dark, connectivity=1)
    area = np.bincount(labels.ravel())
    median = np.median(area[1:][area[1:] > 100])
    return labels, [k for k in range(1, len(area)) if area[k] >= 0.5 * median]


def own_segments(segments: np.ndarray, bricks: np.ndarray, ids: list[int]) -> int:
    """How many of the bricks ``ids`` of ``bricks`` (H, W) have a segment of their own: the
    segment covering most of the brick overlaps it with IoU >= 0.5."""
    hits = 0
    for k in ids:
        inside = bricks == k
        if not inside.any():
            continue
        values, counts = np.unique(segments[inside], return_counts=True)
        best = values[counts.argmax()]
        inter = counts.max()
        union = inside.sum() + (segments == best).sum() - inter
        hits += inter / union >= 0.5
    return int(hits)


def quarters(picture: np.ndarray, bricks: np.ndarray, ids: list[int]):
    """The four quarters of a picture, each with its bricks (those with at least half their
    area in it): (picture, bricks, ids) per quarter."""
    H, W = bricks.shape
    for ys in (slice(0, H // 2), slice(H // 2, H)):
        for xs in (slice(0, W // 2), slice(W // 2, W)):
            part = bricks[ys, xs]
            yield picture[ys, xs], part, [k for k in ids
                                          if 2 * (part == k).sum() >= (bricks == k).sum()]


def flat(bricks: np.ndarray, rng: np.random.Generator, colours: bool = False) -> np.ndarray:
    """(H, W, 3) picture of a brick layout: one grey for the bricks (or a random colour
    each), a lighter one for the mortar, a little noise."""
    out = np.where((bricks > 0)[..., None], BRICK, MORTAR) * np.ones(3)
    if colours:
        palette = rng.random((bricks.max() + 1, 3)) * 0.6 + 0.2
        out[bricks > 0] = palette[bricks[bricks > 0]]
    return np.clip(out + rng.normal(0, NOISE, out.shape), 0, 1)


def main(argv: list[str] | None = None) -> int:
    from skimage.transform import resize

    from neuraltex.baselines import get_segmenter
    from neuraltex.data.datasets import ProceduralTextures
    from neuraltex.imageio import load_image

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--image", type=Path, default=ROOT / "data" / "real_textures" / "brick.png",
                   help="a photograph of bricks darker than their joints")
    p.add_argument("--procedural", type=int, default=6,
                   help="procedural bricks pictures (128 px) for the last row")
    p.add_argument("--checkpoint", default=None, help="E_s export (default: the shipped model)")
    p.add_argument("--tile", choices=("auto", "on"), default="auto",
                   help="E_s also encoding from tiles: as the commands do by default (auto: "
                   "tiles for dense pictures) or always (on); neuraltex/tiled_encode.py")
    p.add_argument("--queries", type=int, nargs="*", default=[196, 400],
                   help="also run E_s with its queries resampled to these counts")
    args = p.parse_args(argv)
    photo = load_image(args.image).permute(1, 2, 0).numpy().astype(np.float64)
    bricks, ids = photo_bricks(photo.mean(2))
    rng = np.random.default_rng(0)
    methods = {"E_s": get_segmenter("model", checkpoint=args.checkpoint),
               f"E_s, tile {args.tile}": get_segmenter("model", checkpoint=args.checkpoint,
                                                       tile=args.tile),
               "felzenszwalb": get_segmenter("felzenszwalb"), "kmeans": get_segmenter("kmeans")}
    half = tuple(side // 2 for side in bricks.shape)
    rows = {"the photograph": [(photo, bricks, ids)],
            "the photograph at half size": [(resize(photo, half, anti_aliasing=True),
                                             resize(bricks, half, order=0, anti_aliasing=False,
                                                    preserve_range=True).astype(int), ids)],
            "the photograph turned 90 degrees": [(np.rot90(photo).copy(),
                                                  np.rot90(bricks).copy(), ids)],
            "the photograph cut in quarters": list(quarters(photo, bricks, ids)),
            "its bricks drawn flat": [(flat(bricks, rng), bricks, ids)],
            "its bricks, a colour each": [(flat(bricks, rng, colours=True), bricks, ids)]}
    data = ProceduralTextures(args.procedural, size=128, seed=0, families=["bricks"])
    rows["procedural bricks drawn flat"] = []
    for i in range(args.procedural):
        item = data[i]
        labels = item["mask"].numpy()
        values, counts = np.unique(labels, return_counts=True)
        mortar = values[counts.argmax()]  # the joints: the largest segment
        layout = np.where(labels == mortar, 0, labels + 1)
        rows["procedural bricks drawn flat"].append(
            (flat(layout, rng), layout, [int(v) + 1 for v in values if v != mortar]))
    for queries in args.queries:  # E_s with its queries resampled (neuraltex.query_grid)
        seg = get_segmenter("model", checkpoint=args.checkpoint, num_queries=queries)
        hits = own_segments(seg(photo), bricks, ids)
        print(f"E_s with {queries} queries on the photograph: {hits} of {len(ids)} bricks")
    print(f"Bricks with a segment of their own (IoU >= 0.5), {args.image.name}: {len(ids)} bricks")
    print("| picture | bricks | " + " | ".join(methods) + " |\n|---|---:|"
          + "---:|" * len(methods))
    for name, pictures in rows.items():
        total = sum(len(k) for _, _, k in pictures)
        hits = {m: sum(own_segments(seg(x), b, k) for x, b, k in pictures)
                for m, seg in methods.items()}
        print(f"| {name} | {total} | " + " | ".join(
            f"{h} ({100 * h / total:.0f} %)" for h in hits.values()) + " |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
