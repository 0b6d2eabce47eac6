"""Benchmark of ``neuraltex synthesize`` on the real textures, beside its baselines.

For each texture of data/real_textures (256 px): ``neuraltex fit --steps N`` (cached), then
at every output size ours (``neuraltex synthesize X.ntex --source X.png``: the texture
file's textons arranged by cvt, decoded by its tuned decoder, the placed elements bringing
the input's pixels), 2 x 2 tiling of the input, random placement of the same elements (same
decoder, background layer, paste and fill; ``random_g``: of their whole groups, the stronger
baseline where ours arranged its textons one by one) and image quilting (Efros-Freeman
2001), all scored against the input by multi-scale patch-SWD, a random-CNN Gram distance and
the repetition measure (scripts/synthesis_baselines.py says what each is); with
``--tileable`` also ours tileable at the first size, scored by its seam. Prints one row per
texture and size (``ours_R``: the same arrangement pasted from the reconstruction, what the
texture file alone gives without --source; ``decoded``: ours before any paste; ``recon``:
the tuned reconstruction at its own size), then the targets of the issue; ``--gallery``
writes input | tiling | quilting | ours decoded only | ours for a few textures.

    python scripts/eval_synthesis.py --steps 300 --cache /tmp/eval_synthesis --tileable \
        --gallery docs/synthesis_gallery.jpg
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import eval_cvt_seam as cvt_seam  # noqa: E402
import synthesis_baselines as base  # noqa: E402

from cvt.seam import MARGIN_RATIO, misaligned  # noqa: E402
from neuraltex.texton_groups import texton_groups  # noqa: E402
from neuraltex.texton_synthesis import (  # noqa: E402
    ArrangeSettings,
    decode_arranged,
    layers,
    paste_arranged,
    place,
    reconstruction,
    source_pixels,
    steady_background,
    synthesize_texture,
)

# ours_R: ours pasted from the reconstruction (a texture file without --source); decoded:
# ours before the paste (the decode alone); recon: the reconstruction at its own size
METHODS = ("ours", "ours_R", "decoded", "tiling", "random", "random_g", "quilting", "recon")
SEAM_LINES = 16  # the wrap band is also ranked among the bands at k / 16 inside
REP_TIE = 1e-3  # repetition: closer by less than this is a tie
SEAM_SHIFT = 4  # px out of register of the real-seam reference (eval_cvt_seam.py --shift)
GALLERY = ("brick", "leopard", "java_beans", "gravel", "leaves", "cells_ihc")


def texture_file(image: Path, cache: Path, steps: int) -> Path:
    """The cached texture file of ``image`` (``neuraltex fit --steps``; fitted if missing)."""
    from neuraltex.cli import main

    out = cache / f"{image.stem}.ntex"
    if not out.exists():
        cache.mkdir(parents=True, exist_ok=True)
        if main(["fit", str(image), "-o", str(out), "--steps", str(steps), "--seed", "0"]):
            raise SystemExit(f"fit failed on {image}")
    return out


def outputs(model, tex, image: np.ndarray, size, seed: int) -> tuple[dict, float, str]:
    """({method: picture (H, W, 3)}, seconds of ours, what ours arranged: "groups",
    "alone" or "lattice") at ``size`` = (H, W). ``image`` (h, w, 3) is the input, ours' source
    of pixels;
    ``ours_R``: the same arrangement pasted from the reconstruction instead; ``decoded``: ours
    before the elements bring any pixels (the arranged textons decoded). Random placement
    places the same elements as ours, over the same steady background layer, decoded and
    then pasted from the input the same way."""
    textons, decoder = tex.textons, tex.decoder
    source = torch.from_numpy(image).permute(2, 0, 1)
    t = time.perf_counter()
    ours, arr = synthesize_texture(decoder, textons, tex.short, size, ArrangeSettings(seed=seed),
                                   labels=tex.labels, source=source)
    seconds = time.perf_counter() - t
    recon = reconstruction(decoder, textons, tex.short)
    ours_r = paste_arranged(textons, arr.rows, arr.groups, arr.placements, recon, tex.labels,
                            tex.short, arr.decoded)
    pixels = source_pixels(source, recon.shape[-2:])
    plain = decoder.generator.feature_channels - 2
    _, _, back = layers(textons, channels=plain)
    steady = steady_background(textons, back, plain, tex.short, decoder.cutoff)
    canvas = (size[1] / tex.short, size[0] / tex.short)

    def random(groups: list[list[int]]) -> torch.Tensor:
        placed = base.random_placement(textons, arr.rows, groups, size, tex.short, seed)
        each = [(e, dx, dy) for g, dx, dy in placed for e in groups[g]]
        out = decode_arranged(decoder, place(steady, arr.rows, each, back, canvas), size,
                              background=len(back))
        if tex.labels is not None:
            out = paste_arranged(textons, arr.rows, groups, placed, pixels, tex.labels,
                                 tex.short, out, period=arr.period)
        return out

    kept = arr.kept
    rand = random(arr.groups)
    # the same elements' whole groups (what ours arranges when it keeps groups): where ours
    # kept its textons one by one, random placement of groups is the stronger baseline
    grouped = texton_groups(steady, arr.rows, extent=ArrangeSettings().group_extent)
    pics = {"ours": ours, "ours_R": ours_r, "decoded": arr.decoded,
            "tiling": base.tiling(image, size), "random": rand,
            "random_g": rand if kept == "groups" else random(grouped),
            "quilting": base.quilting(image, size, seed),
            "recon": recon.clamp(0, 1)}  # recon: at the input size, a reference only
    return {k: _hwc(v) for k, v in pics.items()}, seconds, kept


def _hwc(x) -> np.ndarray:
    if isinstance(x, torch.Tensor):
        return x.permute(1, 2, 0).cpu().numpy()
    return np.asarray(x, np.float32)


def scores(image: np.ndarray, pics: dict) -> dict:
    return {m: {"swd": base.swd(image, p), "gram": base.gram_distance(image, p),
                "rep": base.repetition(p), "rep_c": base.repetition_circular(p)}
            for m, p in pics.items()}


def mean_scores(runs: list[dict]) -> dict:
    """The scores of several seeds' outputs (:func:`scores` each), averaged per method and
    measure."""
    return {m: {k: float(np.mean([r[m][k] for r in runs])) for k in runs[0][m]}
            for m in runs[0]}


def tileable_seam(tex, image: np.ndarray, size, seeds: list[int]) -> dict:
    """Ours tileable at ``size``, scored by its seam: each measure is the mean over the
    outputs of ``seeds`` (one output's band score swings several-fold with what its bands
    happen to cross); ``lines``: per tile cvt's per-line seam values (both measures of
    scripts/eval_cvt_seam.py), of the tile and of the tile cut out of register by
    SEAM_SHIFT px (a real seam, for scale)."""
    source = torch.from_numpy(image).permute(2, 0, 1)
    runs, lines, cut, tiles = [], [], [], []
    for seed in seeds:
        pic, _ = synthesize_texture(tex.decoder, tex.textons, tex.short, size,
                                    ArrangeSettings(seed=seed, tileable=True),
                                    labels=tex.labels, source=source)
        pic = _hwc(pic)
        tiles.append(pic)
        runs.append((base.seam(pic), *base.seam_swd(pic, image, lines=SEAM_LINES)))
        lines.append(cvt_seam.lines_of(pic, cvt_seam.MEASURES))
        cut.append(cvt_seam.lines_of(misaligned(pic, SEAM_SHIFT), cvt_seam.MEASURES))
    step, wrap, inside = (float(np.mean([r[i] for r in runs])) for i in range(3))
    spread = np.mean([r[3] for r in runs], axis=0)
    out = {"seam": step, "seam_swd": wrap, "inner_swd": inside, "inner_lines": spread,
           "rank": int((spread < wrap).sum()), "seeds": len(runs),
           "tiling_seam": base.seam(base.tiling(image, size)), "lines": lines, "cut": cut,
           "tile": tiles[0]}
    out["ratios"] = line_ratios(out)
    out["input"] = input_wrap(image)
    return out


def input_wrap(image: np.ndarray) -> dict[str, float]:
    """cvt's seam / interior of the input picture's own wrap, per measure: the reference for
    an input that repeats a tile, whose lattice output wraps at a tile border (a border with
    grout lines, or a tile that is not quite seamless, reads high on the input too)."""
    lines = [cvt_seam.lines_of(image, cvt_seam.MEASURES)]
    return {m: float(cvt_seam.own_seams(lines, m)[0]) for m in cvt_seam.MEASURES}


def line_ratios(tile: dict, rolls: int = 2000, measures=tuple(cvt_seam.MEASURES)
                ) -> dict[str, tuple[float, np.ndarray, float]]:
    """Per cvt seam measure: (the tiles' seam / interior, the same tiles rolled to random
    lines (seamless by construction: the measure's noise), the tiles cut out of register)."""
    return {m: (float(cvt_seam.own_seams(tile["lines"], m)[0]),
                cvt_seam.rolled_seams(tile["lines"], m, rolls),
                float(cvt_seam.own_seams(tile["cut"], m)[0])) for m in measures}


def row_text(name: str, size, sc: dict, seconds: float, rep_in: dict, kept: str) -> str:
    cells = " ".join(f"{sc[m]['swd']:7.3f} {sc[m]['gram']:6.4f}" for m in METHODS)
    reps = "  ".join(f"{label} in/tile/ours/quilt {rep_in[k]:.3f}/{sc['tiling'][k]:.3f}/"
                     f"{sc['ours'][k]:.3f}/{sc['quilting'][k]:.3f}"
                     for k, label in (("rep", "rep"), ("rep_c", "rep circular")))
    return f"{name:12s} {size[0]}x{size[1]:<4d} {cells}   {reps}  {seconds:5.1f} s  {kept:7s}"


def not_repeating(r: dict, key: str = "rep") -> bool:
    """The repetition target: ours is not closer to the 2 x 2 tiling's value of measure
    ``key`` than to the input's, up to REP_TIE (the printed precision): on an input that
    repeats exactly, input, tiling and its continuation all read 1 and differ in the last
    bits of a float."""
    ours = r["sc"]["ours"][key]
    return abs(ours - r["rep_in"][key]) <= abs(ours - r["sc"]["tiling"][key]) + REP_TIE


def summary(results: list[dict]) -> list[str]:
    lines = []
    for size in sorted({r["size"] for r in results}):
        rs = [r for r in results if r["size"] == size]
        n = len(rs)
        pairs = [p for r in rs for p in r["per_seed"]]  # (ours, random) of every seed
        beat_dec = sum(r["sc"]["ours"]["swd"] < r["sc"]["decoded"]["swd"] for r in rs)
        beat_rand = sum(r["sc"]["ours"]["swd"] < r["sc"]["random"]["swd"] for r in rs)
        beat_both = sum(r["sc"]["ours"]["swd"] < min(r["sc"]["random"]["swd"],
                                                     r["sc"]["random_g"]["swd"]) for r in rs)
        beat_q, beat_q_r = (sum(r["sc"][m]["swd"] < r["sc"]["quilting"]["swd"]
                                or r["sc"][m]["gram"] < r["sc"]["quilting"]["gram"] for r in rs)
                            for m in ("ours", "ours_R"))
        ceiling = sum(r["sc"]["recon"]["swd"] < r["sc"]["quilting"]["swd"]
                      or r["sc"]["recon"]["gram"] < r["sc"]["quilting"]["gram"] for r in rs)
        no_rep, no_rep_c = (sum(not_repeating(r, k) for r in rs) for k in ("rep", "rep_c"))
        means = {m: (np.mean([r["sc"][m]["swd"] for r in rs]),
                     np.mean([r["sc"][m]["gram"] for r in rs])) for m in METHODS}
        lines += [f"{size[0]}x{size[1]} ({n} textures): mean swd/gram "
                  + ", ".join(f"{m} {s:.1f}/{g:.3f}" for m, (s, g) in means.items()),
                  f"  ours < random placement on patch-SWD: {beat_rand}/{n} (target: all; "
                  f"{len(pairs) // n} seed(s) each, their mean; single seeds: "
                  f"{sum(o < r for o, r in pairs)}/{len(pairs)})",
                  f"  ours < random placement, the better of the same elements and their "
                  f"whole groups (random_g), on patch-SWD: {beat_both}/{n}",
                  f"  ours < decoded (the arrangement decoded, no paste) on patch-SWD: "
                  f"{beat_dec}/{n}",
                  f"  ours < quilting on patch-SWD or gram: {beat_q}/{n} (target >= 60%)",
                  f"  ours_R (pixels of the reconstruction) < quilting on patch-SWD or gram: "
                  f"{beat_q_r}/{n}",
                  f"  recon < quilting on patch-SWD or gram: {ceiling}/{n} (the reconstruction, "
                  "whose pixels ours_R copies)",
                  f"  repetition not closer to the tiling's than to the input's: {no_rep}/{n} "
                  f"(circular autocorrelation, biased by the canvas: {no_rep_c}/{n})",
                  f"  ours seconds: mean {np.mean([r['seconds'] for r in rs]):.1f}, "
                  f"max {np.max([r['seconds'] for r in rs]):.1f} (target <= 30 at 512x512)"]
    return lines + seam_summary([r["tile"] for r in results if "tile" in r])


def seam_summary(seams: list[dict]) -> list[str]:
    if not seams:
        return []
    n = len(seams)
    ok = sum(s["seam_swd"] <= 1.1 * s["inner_swd"] for s in seams)
    typical = sum(s["seam_swd"] <= np.quantile(s["inner_lines"], 0.9) for s in seams)
    steps = sum(s["seam"] <= 1.1 for s in seams)
    k = seams[0]["seeds"]
    per = f"each measure the mean of {k} outputs'; " if k > 1 else ""
    return [f"tileable ({n}; {per}a seam if the wrap is worse than inside): seam step ratio "
            f"mean {np.mean([s['seam'] for s in seams]):.2f} "
            f"(tiling of the input: {np.mean([s['tiling_seam'] for s in seams]):.2f}), "
            f"<= 1.1 on {steps}/{n}; band patch-SWD across the wrap <= 1.1 x inside (the lines "
            f"at 1/4, 1/2, 3/4) on {ok}/{n}; within the 90th percentile of the "
            f"{SEAM_LINES - 1} interior lines' bands on {typical}/{n}"] + [
        _pooled_lines(seams, m) for m in cvt_seam.MEASURES]


def _pooled_lines(seams: list[dict], m: str) -> str:
    """cvt's seam / interior for measure ``m`` over every tile of every texture, per texture
    within MARGIN_RATIO, and the seamless (rolled) and real (cut) references."""
    per = [s["ratios"][m] for s in seams]
    w = np.array([s["seeds"] for s in seams], float)
    null = np.average(np.stack([p[1] for p in per]), axis=0, weights=w)
    pooled = float(np.average([p[0] for p in per], weights=w))
    return (f"  {m} (cvt.seam, seam line / interior): pooled {pooled:.3f}; within "
            f"{MARGIN_RATIO} on {sum(p[0] <= MARGIN_RATIO for p in per)}/{len(per)} textures "
            f"(rolled, seamless, within it on {sum(np.mean(p[1] <= MARGIN_RATIO) for p in per):.1f}"
            f" on average); pooled rolled 5-95 % {np.quantile(null, 0.05):.3f}-"
            f"{np.quantile(null, 0.95):.3f}; cut {SEAM_SHIFT} px out of register "
            f"{np.average([p[2] for p in per], weights=w):.2f}, over {MARGIN_RATIO} on "
            f"{sum(p[2] > MARGIN_RATIO for p in per)}/{len(per)}")


def seam_text(tile: dict) -> str:
    cvt = "; ".join(f"{m} {r:.2f} (rolled 5-95 % {np.quantile(null, 0.05):.2f}-"
                    f"{np.quantile(null, 0.95):.2f}, cut {cut:.2f})"
                    for m, (r, null, cut) in tile["ratios"].items())
    return (f"  seam {tile['seam']:.2f} swd wrap/in {tile['seam_swd']:.1f}/"
            f"{tile['inner_swd']:.1f} interior lines {tile['inner_lines'].min():.1f}-"
            f"{tile['inner_lines'].max():.1f} wrap above {tile['rank']}/{SEAM_LINES - 1}"
            f"\n    lines (cvt.seam): {cvt}"
            + ("; the input's own wrap: " + ", ".join(f"{m} {v:.2f}" for m, v in
                                                      tile["input"].items())
               if "input" in tile else ""))


def gallery(rows: list[tuple[np.ndarray, dict]], path: Path) -> None:
    """input | tiling | quilting | ours decoded only (the arranged textons, before the paste) |
    ours from the reconstruction's pixels (the texture file alone) | ours, one texture a row
    (JPEG to keep docs small)."""
    from PIL import Image

    tiles = []
    for image, pics in rows:
        size = pics["ours"].shape[:2]
        cell = np.ones((*size, 3), np.float32)
        cell[:image.shape[0], :image.shape[1]] = image
        tiles.append(np.concatenate([cell, pics["tiling"], pics["quilting"], pics["decoded"],
                                     pics["ours_R"], pics["ours"]], 1))
    pic = (np.clip(np.concatenate(tiles, 0), 0, 1) * 255).round().astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pic).save(path, quality=88)
    print(f"wrote {path}")


def seam_gallery(tiles: list[np.ndarray], path: Path, side: int = 384) -> None:
    """Each tileable tile (its first seed's) tiled 2 x 2 at ``side`` px, the wrap through
    the middle of each cell, three a row (JPEG)."""
    from PIL import Image

    cells = [np.asarray(Image.fromarray((np.clip(np.tile(t, (2, 2, 1)), 0, 1) * 255).round()
                                        .astype(np.uint8)).resize((side, side), Image.LANCZOS))
             for t in tiles]
    cells += [np.full_like(cells[0], 255)] * (-len(cells) % 3)
    rows = [np.concatenate(cells[k:k + 3], 1) for k in range(0, len(cells), 3)]
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.concatenate(rows, 0)).save(path, quality=88)
    print(f"wrote {path}")


def add_texture_options(p: argparse.ArgumentParser) -> None:
    """--textures, --cache and --steps: where the real textures and their texture files are."""
    p.add_argument("--textures", type=Path, default=ROOT / "data" / "real_textures",
                   help="folder of real textures (default data/real_textures; the held-out "
                   "set: data/real_textures_heldout)")
    p.add_argument("--cache", type=Path, default=Path("/tmp/eval_synthesis"),
                   help="texture files (.ntex) are fitted once and kept here")
    p.add_argument("--steps", type=int, default=300, help="fit steps per texture")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_texture_options(p)
    p.add_argument("--sizes", nargs="+", default=["512x512", "256x768"], help="HxW outputs")
    p.add_argument("--only", nargs="+", help="texture names (default: all)")
    p.add_argument("--tileable", action="store_true", help="also score ours tileable")
    p.add_argument("--gallery", type=Path, help="write the gallery (JPEG) here")
    p.add_argument("--seam-only", action="store_true",
                   help="only ours tileable at the first size, scored by its seam")
    p.add_argument("--seam-gallery", type=Path,
                   help="with --seam-only: write the first six textures' tiles, each tiled "
                        "2 x 2, here (JPEG)")
    p.add_argument("--seed", type=int, default=0,
                   help="first seed of ours, random placement and quilting (default 0)")
    p.add_argument("--seeds", type=int, default=1,
                   help="outputs per texture and size, with seeds --seed, --seed + 1, ...: "
                        "every method's scores are their mean (one seed's patch-SWD swings "
                        "several-fold with where the elements fall)")
    args = p.parse_args()
    if args.seeds < 1:
        p.error("--seeds must be >= 1")
    torch.set_num_threads(1)
    from neuraltex.cli import common
    from neuraltex.imageio import load_image
    from neuraltex.limits import Limits

    model = common.load(None)
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes]
    names = args.only or sorted((f.stem for f in args.textures.glob("*.png")),
                                key=lambda n: (n not in GALLERY, n))  # the gallery's first
    shown = set(GALLERY) & set(names) or set(names[:len(GALLERY)])  # another set: its first
    results, rows, seams = [], [], []
    seeds = list(range(args.seed, args.seed + args.seeds))
    for name in names:
        path = args.textures / f"{name}.png"
        tex = common.textons_of(model, texture_file(path, args.cache, args.steps), Limits())
        image = load_image(path).permute(1, 2, 0).numpy()
        if args.seam_only:
            seams.append(tileable_seam(tex, image, sizes[0], seeds))
            print(f"{name:12s} {sizes[0][0]}x{sizes[0][1]:<4d}" + seam_text(seams[-1]),
                  flush=True)
            continue
        rep_in = {"rep": base.repetition(image), "rep_c": base.repetition_circular(image)}
        for k, size in enumerate(sizes):
            runs = [outputs(model, tex, image, size, seed) for seed in seeds]
            pics, kept = runs[0][0], runs[0][2]  # the gallery shows the first seed
            each = [scores(image, run[0]) for run in runs]
            seconds = float(np.mean([run[1] for run in runs]))
            r = {"name": name, "size": size, "sc": mean_scores(each), "seconds": seconds,
                 "rep_in": rep_in,
                 "per_seed": [(e["ours"]["swd"], e["random"]["swd"]) for e in each]}
            if args.tileable and k == 0:
                r["tile"] = tileable_seam(tex, image, size, seeds)
            results.append(r)
            print(row_text(name, size, r["sc"], seconds, rep_in, kept)
                  + (seam_text(r["tile"]) if "tile" in r else ""), flush=True)
            if args.seeds > 1:
                print("  ours / random patch-SWD per seed: " + ", ".join(
                    f"{o:.3f} / {q:.3f}" for o, q in r["per_seed"]), flush=True)
            if k == 0 and name in shown:
                rows.append((image, pics))
                if args.gallery:
                    gallery(rows, args.gallery)
    if args.seam_only:
        print("\n".join(seam_summary(seams)))
        if args.seam_gallery:
            seam_gallery([t["tile"] for t in seams[:6]], args.seam_gallery)
        return
    print(f"\ncolumns: swd gram for {', '.join(METHODS)}")
    print("\n".join(summary(results)))


if __name__ == "__main__":
    main()
