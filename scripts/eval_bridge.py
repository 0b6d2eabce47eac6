"""Bridge benchmark: raster texture -> texton elements (SVG) -> 2x clustered vector synthesis.

    python scripts/eval_bridge.py --limit 8 --real 3               # the shipped model
    python scripts/eval_bridge.py --limit 0 --real 25 --synth --out docs/bridge_real.md
    python scripts/eval_bridge.py --pipelines felzenszwalb --limit 8 --no-gradient

Inputs: the first ``--limit`` procedural benchmark images (neuraltex.data.splits, families in
turn; true texton masks known) and the first ``--real`` photographed textures of
data/real_textures (see its SOURCES.md), all at ``--size`` px. Pipelines: the texton model
(``model``), the segments a texture file stores (``fit``: ``neuraltex fit --segmenter auto``),
the same vectorizer on Felzenszwalb segments (``felzenszwalb``), and **vtracer** (a colour
raster -> SVG tracer from PyPI, default settings) as an outside baseline.

Vectorization: the SVG rasterized at the input size (resvg) vs the input: PSNR, SSIM; element
count and SVG size; on procedural images also the true texton count and the matched IoU of the
rasterized element shapes vs the true masks (neuraltex.metrics). ``--synth``: the 2x synthesis
as ``cvt synthesize --from-image`` makes it (the picture's lattice, if it repeats a tile, else
cvt's pattern pipeline, ``--levels`` x ``--iterations``; ``lattice`` says which) rasterized
vs the input by patch SWD x 1000 (as in the vector benchmark; ``ex_swd`` is the exemplar's
own, the floor the synthesis inherits), its final energy and time. Means per pipeline and
input kind at the end.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import torch  # noqa: E402

from cvt.metrics import patch_swd  # noqa: E402
from cvt.raster import element_mask, render_svg  # noqa: E402
from neuraltex.fileio import write_text_atomic  # noqa: E402
from neuraltex.segments import segment_image  # noqa: E402
from neuraltex.tiled_segments import TILING  # noqa: E402
from neuraltex.vectorize import VectorizeParams, to_svg, vectorize  # noqa: E402

REAL = ROOT / "data" / "real_textures"
PIPELINES = ("model", "fit", "felzenszwalb", "vtracer")
VECTOR_COLS = ("psnr", "ssim", "elements", "gt", "miou", "kib", "t_vec")
SYNTH_COLS = ("ex_swd", "swd", "out_elements", "energy", "lattice", "t_syn")


def inputs(limit: int, real: int, size: int, only: list[str] | None = None,
           folder: Path = REAL):
    """[(name, image (H, W, 3) float64 in [0, 1], true masks (H, W) or None)]; the real
    textures from ``folder``; ``only``: these instead of the first ``real``."""
    from PIL import Image

    from neuraltex.data.splits import benchmark_split

    out = []
    for item in benchmark_split()[:limit]:
        s = generate_at(item, size)
        out.append((f"{item.family}-{item.index}", s.image.astype(np.float64), s.mask))
    paths = [folder / f"{n}.png" for n in only] if only else sorted(folder.glob("*.png"))[:real]
    for path in paths:
        if not path.exists():
            raise SystemExit(f"no real texture {path.stem} in {folder}")
        pic = Image.open(path).convert("RGB").resize((size, size), Image.LANCZOS)
        out.append((path.stem, np.asarray(pic, np.float64) / 255, None))
    return out


def generate_at(item, size: int):
    from neuraltex.data import generate

    return generate(item.index, item.seed, size, family=item.family)


def element_labels(svg: str, shape: tuple[int, int]) -> np.ndarray:
    """Rasterized element shapes as labels, later elements on top; 0 = background layer."""
    from cvt.svg import parse_svg

    labels = np.zeros(shape, np.int64)
    for k, e in enumerate(parse_svg(svg.encode()).elements):
        if e.node.get("data-background") == "1":
            continue
        m = element_mask(e, 0.0, 0.0, np.zeros(2), 1.0)
        y0, x0 = max(m.y0, 0), max(m.x0, 0)
        crop = m.pixels[y0 - m.y0 : shape[0] - m.y0, x0 - m.x0 : shape[1] - m.x0]
        view = labels[y0 : y0 + crop.shape[0], x0 : x0 + crop.shape[1]]
        view[crop] = k + 1
    return labels


def vector_row(image: np.ndarray, gt, pipeline: str, model, params: VectorizeParams,
               source: str, tile: str = "auto") -> tuple[dict, str]:
    from skimage.metrics import peak_signal_noise_ratio, structural_similarity

    from neuraltex.metrics import matched_miou

    t = time.perf_counter()
    if pipeline == "vtracer":
        svg, count = vtracer_svg(image)
    else:
        seg = segments(image, pipeline, model, source, tile)
        vec = vectorize(image, seg, params)
        svg, count = to_svg(vec, seg, params.seam), len(vec.elements)
    row = {"t_vec": time.perf_counter() - t, "elements": count,
           "kib": len(svg.encode()) / 1024}
    out = render_svg(svg).astype(np.float64)
    row["psnr"] = peak_signal_noise_ratio(image, out, data_range=1.0)
    row["ssim"] = structural_similarity(image, out, channel_axis=2, data_range=1.0)
    row["gt"] = len(np.unique(gt[gt > 0])) if gt is not None else float("nan")
    row["miou"] = matched_miou(element_labels(svg, gt.shape), gt) if gt is not None else math.nan
    return row, svg


def segments(image: np.ndarray, pipeline: str, model, source: str, tile: str = "auto"):
    """The segments a pipeline vectorizes (``model``: the picture encoded whole or from tiles
    as ``tile`` says); ``fit``: the ones a texture file stores."""
    x = torch.from_numpy(image).permute(2, 0, 1).float()
    if pipeline != "fit":
        return segment_image(x, pipeline, model, source, tile=tile)[0]
    from neuraltex.fit import choose_segments
    from neuraltex.segments import drop_background, from_labels

    _, _, labels = choose_segments(model, x, "auto", 400)
    return drop_background(from_labels(labels, image))


def vtracer_svg(image: np.ndarray) -> tuple[str, int]:
    """vtracer's colour tracing of an image (default settings) and its path count."""
    import io

    import vtracer
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray((image * 255).round().astype(np.uint8)).save(buf, format="PNG")
    svg = vtracer.convert_raw_image_to_svg(buf.getvalue(), img_format="png", colormode="color")
    return svg, svg.count("<path")


def synth_row(image: np.ndarray, svg: str, args) -> dict:
    """The 2x synthesis as ``cvt synthesize --from-image`` runs it: the picture's lattice
    (neuraltex.raster_lattice, unless ``--no-lattice``) tiles the output with the exemplar's
    cells, else cvt's pattern pipeline (the seed method, density repair) arranges the
    elements freely (single elements: a picture's segments are no composites); rasterized
    with the exemplar's backdrop."""
    from cvt.from_textons import image_exemplar, with_backdrop
    from cvt.pattern import PatternOptions, pattern_svg, synthesize_pattern
    from cvt.synthesis import SynthesisConfig
    from neuraltex.raster_lattice import raster_lattice

    ie = image_exemplar(svg)
    ex = ie.exemplar
    size = (ex.viewbox[2] * 2, ex.viewbox[3] * 2)
    cfg = SynthesisConfig(levels=args.levels, iterations=args.iterations, seed=args.seed,
                          init=args.init, w_a=args.w_a)
    lattice = None if args.no_lattice else raster_lattice(image)
    opts = PatternOptions(lattice=not args.no_lattice, basis=lattice, composites=False)
    t = time.perf_counter()
    pattern = synthesize_pattern(ex, size, cfg, "full", opts)
    res = pattern.result
    row = {"t_syn": time.perf_counter() - t, "out_elements": len(pattern.placements),
           "energy": res.energies[-1][2] if res is not None and res.energies else math.nan,
           "lattice": "no" if lattice is None else "yes"}
    out = render_svg(with_backdrop(pattern_svg(ex, pattern, opts), ie.backdrop))
    row["swd"] = patch_swd(out, image)
    row["ex_swd"] = patch_swd(render_svg(svg), image)
    return row


def _mean(values: list):
    """The mean of a column (NaN where all are missing); of a yes / no column, "k/n" yes."""
    if isinstance(values[0], str):
        return f"{sum(v == 'yes' for v in values)}/{len(values)}"
    return math.nan if all(math.isnan(v) for v in values) else float(np.nanmean(values))


def _fmt(v) -> str:
    if isinstance(v, str):
        return v
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    return f"{v:.0f}" if isinstance(v, int) or abs(v) >= 100 else f"{v:.3f}"


def _table(head, rows) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(_fmt(v) for v in r) + " |" for r in rows])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--checkpoint", help="texton model .safetensors (default: the shipped one)")
    ap.add_argument("--pipelines", nargs="+", default=list(PIPELINES), choices=PIPELINES,
                    help="what vectorizes (default: all)")
    ap.add_argument("--limit", type=int, default=8, help="procedural benchmark images")
    ap.add_argument("--real", type=int, default=25, help="real textures (data/real_textures)")
    ap.add_argument("--textures", type=Path, default=REAL,
                    help="folder of real textures (default data/real_textures; the held-out "
                    "set: data/real_textures_heldout)")
    ap.add_argument("--only", nargs="+", metavar="NAME",
                    help="these real textures of data/real_textures instead of the first --real")
    ap.add_argument("--size", type=int, default=128, help="input side in px (default 128)")
    ap.add_argument("--source", choices=("masks", "splat"), default="masks",
                    help="model pipeline: element shapes from the masks (default) or from the "
                    "splatted Gaussians")
    ap.add_argument("--tile", choices=TILING, default="auto",
                    help="model pipeline: encode the picture whole (off), from tiles (on), or "
                    "from tiles where it is dense (auto, as the commands; neuraltex."
                    "tiled_encode)")
    ap.add_argument("--no-gradient", action="store_true",
                    help="flat-coloured elements (no linear gradient fills)")
    ap.add_argument("--synth", action="store_true",
                    help="also the 2x vector synthesis, as cvt synthesize --from-image runs it")
    ap.add_argument("--no-lattice", action="store_true",
                    help="--synth arranges freely even where the picture repeats a tile (as "
                    "cvt synthesize --no-lattice)")
    ap.add_argument("--levels", type=int, default=3, help="--synth: cvt levels (default 3)")
    ap.add_argument("--iterations", type=int, default=7,
                    help="--synth: iterations per level (default 7)")
    ap.add_argument("--init", choices=("patch", "random", "gaussian"), default="patch",
                    help="--synth: cvt's initialization (default patch)")
    ap.add_argument("--w-a", type=float, default=1.0, help="appearance (kind) weight")
    ap.add_argument("--seed", type=int, default=0, help="--synth: seed (default 0)")
    ap.add_argument("--out", help="also write the tables to this Markdown file")
    args = ap.parse_args()
    torch.set_num_threads(1)
    from neuraltex.model import DEFAULT_MODEL, load_model

    model = load_model(args.checkpoint or DEFAULT_MODEL)
    params = VectorizeParams(gradient=not args.no_gradient)
    cols = VECTOR_COLS + (SYNTH_COLS if args.synth else ())
    rows, results = [], []
    data = inputs(args.limit, args.real, args.size, args.only, args.textures)
    bar = tqdm([(d, p) for d in data for p in args.pipelines], file=sys.stderr, unit="run")
    for (name, image, gt), pipe in bar:
        bar.set_description(f"{name} / {pipe}")
        row, svg = vector_row(image, gt, pipe, model, params, args.source, args.tile)
        if args.synth:
            row.update(synth_row(image, svg, args))
        results.append((gt is not None, pipe, row))
        rows.append([name, pipe] + [row[c] for c in cols])
    bar.close()
    means = []
    for kind, label in ((True, "procedural"), (False, "real")):
        for pipe in args.pipelines:
            sel = [r for k, p, r in results if k == kind and p == pipe]
            if sel:
                means.append([label, pipe] + [_mean([r[c] for r in sel]) for c in cols])
    setting = (f"{args.size} px, source {args.source}, tile {args.tile}, gradients "
               f"{'off' if args.no_gradient else 'on'}"
               + (f"; synthesis 2x, {args.levels} levels x {args.iterations} iterations, "
                  f"init {args.init}, w_a {args.w_a:g}, seed {args.seed}"
                  + (", no lattice" if args.no_lattice else "") if args.synth else ""))
    text = (f"Per input ({setting}):\n\n" + _table(["input", "pipeline", *cols], rows)
            + "\n\nMeans:\n\n" + _table(["inputs", "pipeline", *cols], means) + "\n")
    print(text)
    if args.out:
        write_text_atomic(args.out, text)


if __name__ == "__main__":
    main()
