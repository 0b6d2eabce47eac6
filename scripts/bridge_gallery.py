"""Picture of the bridge: raster input | texton overlay | vector exemplar | 2x vector synthesis.

    python scripts/bridge_gallery.py --checkpoint M.safetensors --out docs/bridge.png discs-0 brick

Inputs are names of scripts/eval_bridge.py (``<family>-<index>`` of the procedural benchmark,
or a scikit-image texture) or image paths. ``--segmenter felzenszwalb`` draws the baseline
(its overlay column then shows the segments without ellipses).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch
from PIL import Image, ImageDraw
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cvt.from_textons import image_exemplar, with_backdrop  # noqa: E402
from cvt.raster import render_svg  # noqa: E402
from cvt.synthesis import SynthesisConfig, result_svg, synthesize  # noqa: E402
from neuraltex.imageio import save_pil, stack_rows  # noqa: E402
from neuraltex.overlay import draw_overlay, palette  # noqa: E402
from neuraltex.segments import segment_image  # noqa: E402
from neuraltex.vectorize import VectorizeParams, to_svg, vectorize  # noqa: E402
from scripts.eval_bridge import REAL, inputs  # noqa: E402


def load_input(name: str, size: int) -> np.ndarray:
    """(H, W, 3) float64 in [0, 1] from a benchmark/scikit-image name or an image path."""
    if Path(name).is_file():
        from neuraltex.imageio import load_image

        return load_image(name, max_side=size).permute(1, 2, 0).numpy().astype(np.float64)
    if name in REAL:
        real = inputs(0, len(REAL), size)
        return next(im for n, im, _ in real if n == name)
    index = int(name.rsplit("-", 1)[1])
    return next(im for n, im, _ in inputs(index + 1, 0, size) if n == name)


def _pic(arr: np.ndarray, height: int) -> Image.Image:
    im = Image.fromarray((np.clip(arr, 0, 1) * 255).round().astype(np.uint8))
    return im.resize((round(im.width * height / im.height), height), Image.NEAREST)


def row(name: str, image: np.ndarray, model, args) -> Image.Image:
    x = torch.from_numpy(image).permute(2, 0, 1).float()
    seg, textons = segment_image(x, args.segmenter, model)
    params = VectorizeParams()
    svg = to_svg(vectorize(image, seg, params), seg, params.seam)
    if textons is not None:
        with torch.no_grad():
            masks = model.encode(x[None]).masks[0]
        overlay = draw_overlay(x, textons, masks, scale=1)
    else:  # baseline: segments tinted by label, no Gaussians
        overlay = _tint(image, seg.labels)
    ie = image_exemplar(svg)
    ex = ie.exemplar
    cfg = SynthesisConfig(levels=args.levels, iterations=args.iterations, seed=args.seed)
    res = synthesize(ex, (ex.viewbox[2] * 2, ex.viewbox[3] * 2), cfg)
    big = render_svg(with_backdrop(result_svg(ex, res), ie.backdrop))
    h = args.height
    tiles = [_pic(image, h), overlay.resize((h, h), Image.NEAREST), _pic(render_svg(svg), h),
             _pic(big, 2 * h)]
    out = Image.new("RGB", (sum(t.width for t in tiles) + 10 * (len(tiles) - 1), 2 * h + 18),
                    "white")
    xpos = 0
    for t in tiles:
        out.paste(t, (xpos, 18))
        xpos += t.width + 10
    label = (f"{name} ({args.segmenter}): input | segments + Gaussians | vector exemplar "
             f"({len(ex.elements)} elements) | 2x vector synthesis ({len(res.placements)})")
    ImageDraw.Draw(out).text((0, 2), label, fill="black")
    return out


def _tint(image: np.ndarray, labels: np.ndarray) -> Image.Image:
    """Segments tinted like draw_overlay's (background pixels, label -1, untinted)."""
    colours = palette(max(int(labels.max()) + 1, 1)).astype(np.float64) / 255
    tinted = np.where(labels[..., None] >= 0, 0.55 * image + 0.45 * colours[labels], image)
    return Image.fromarray((tinted * 255).round().astype(np.uint8))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=["discs-0", "immunohistochemistry"])
    ap.add_argument("--checkpoint", help="texton model .safetensors")
    ap.add_argument("--segmenter", choices=("model", "felzenszwalb"), default="model")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--height", type=int, default=192, help="height of the small tiles")
    ap.add_argument("--levels", type=int, default=3)
    ap.add_argument("--iterations", type=int, default=7)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="docs/bridge.png")
    args = ap.parse_args()
    torch.set_num_threads(1)
    model = None
    if args.segmenter == "model":
        if not args.checkpoint:
            ap.error("--segmenter model needs --checkpoint")
        from neuraltex.model import load_model

        model = load_model(args.checkpoint)
    rows = [row(n, load_input(n, args.size), model, args) for n in tqdm(args.names)]
    save_pil(stack_rows(rows, gap=10), args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
