"""Real-texture benchmark of ``neuraltex fit``: reconstruction, reshuffling, speed and file size
on photographed / scanned textures (data/real_textures, see its SOURCES.md), against references
computed here on the same images:

- flat: the image's mean colour;  blur: 4x box downsample + bicubic upsample;
- kmeans8: the image quantized to 8 k-means colours;
- plain: the fit's PSNR before the detail sprites (neuraltex.texton_detail), i.e. G alone;
- reshuffle: patch-SWD(input, reshuffle by elements, what ``neuraltex reshuffle`` does with a
  texture file: elements trade places in the reconstruction, neuraltex.element_swap; and
  swd_shuf_src / change_src: in the input itself, what ``reshuffle --source`` does) vs
  patch-SWD(input, reconstruction) and vs a random-placement reference (the same textons at
  uniform random positions, same decoder); swd_shuf_d decodes the same elements' textons moved
  instead (the previous version: the tuned decoder renders the new layout); swd_shuf_t is the
  seed's texton reshuffle (features traded between textons of one kind, ``--by textons``);
  moved is the share of elements that moved; change is the mean
  |reshuffle - reconstruction| per pixel and channel (a reshuffle that changes nothing would
  score 0 and match the reconstruction's SWD);
- init: with ``--init-compare N``, the first N images are tuned three more times at the same
  budget, G alone: from the shipped weights with their fit prior (what ``fit`` does,
  neuraltex.fit_prior), from the shipped G without it, and from a randomly initialized model
  (does the pretrained model earn its place?); with ``--init-chain M`` also from the shipped G
  first tuned, in the fit's own regime, on M procedural textures of a training seed in turn.

    python scripts/eval_real.py                      # 25 real textures, default fit budget
    python scripts/eval_real.py --seconds 20 --limit 5 --init-compare 3
    python scripts/eval_real.py --steps 300 --init-compare 3 --init-only
    python scripts/eval_real.py --steps 300 --init-compare 3 --init-chain 4 --init-only
    python scripts/eval_real.py --procedural 10      # procedural benchmark images too

Prints one row per image and the means; ``--out FILE.md`` also writes the table.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cvt.metrics import patch_swd  # noqa: E402
from neuraltex.element_swap import swap_and_count  # noqa: E402
from neuraltex.fit import FitSettings, fit_texture, psnr  # noqa: E402
from neuraltex.imageio import load_image  # noqa: E402
from neuraltex.model import DEFAULT_MODEL, build_model, load_model  # noqa: E402
from neuraltex.reshuffle import reshuffle  # noqa: E402
from neuraltex.texton_elements import reshuffle_elements  # noqa: E402
from neuraltex.texton_kinds import texton_kinds  # noqa: E402
from neuraltex.texture_file import load_texture, save_texture  # noqa: E402
from neuraltex.tuned_decoder import tuned_model  # noqa: E402

REAL = Path(__file__).resolve().parents[1] / "data" / "real_textures"
VISIBLE = 0.005  # mean |reshuffle - reconstruction| of a reshuffle that changes the picture
COLS = ("flat", "blur", "kmeans8", "plain", "fit", "ssim_blur", "ssim_fit", "swd_rec",
        "swd_shuf", "swd_shuf_src", "swd_shuf_d", "swd_shuf_t", "swd_rand", "moved", "change",
        "change_src", "seconds", "steps", "textons", "kib", "edit_s")


def references(image: torch.Tensor) -> dict[str, torch.Tensor]:
    """The three reference reconstructions of an image (3, H, W)."""
    from scipy.cluster.vq import kmeans2

    H, W = image.shape[-2:]
    flat = image.mean((1, 2), keepdim=True).expand_as(image)
    blur = F.interpolate(F.avg_pool2d(image[None], 4), size=(H, W), mode="bicubic",
                         align_corners=False)[0].clamp(0, 1)
    px = image.flatten(1).T.double().numpy()
    centres, labels = kmeans2(px, 8, minit="++", seed=0)
    quant = torch.from_numpy(centres[labels]).float().T.reshape(3, H, W)
    return {"flat": flat, "blur": blur, "kmeans8": quant}


def ssim(a: torch.Tensor, b: torch.Tensor) -> float:
    from skimage.metrics import structural_similarity

    return float(structural_similarity(a.permute(1, 2, 0).numpy(), b.permute(1, 2, 0).numpy(),
                                       channel_axis=2, data_range=1.0))


def swd(a: torch.Tensor, b: torch.Tensor) -> float:
    return patch_swd(a.permute(1, 2, 0).numpy(), b.permute(1, 2, 0).numpy())


def random_placement(textons, seed: int = 0):
    """The same textons at uniform random positions on the canvas."""
    g = torch.Generator().manual_seed(seed)
    w, h = textons.canvas
    mu = torch.rand(textons.mu.shape, generator=g) * torch.tensor([w, h])
    return replace(textons, mu=mu)


def evaluate(model, image: torch.Tensor, settings: FitSettings, workdir: Path) -> dict:
    row = {}
    refs = references(image)
    for name, ref in refs.items():
        row[name] = psnr(ref, image)
    row["ssim_blur"] = ssim(refs["blur"], image)
    fit = fit_texture(model, image, settings)
    path = workdir / "t.ntex"
    header = {"source": {}, "size": list(image.shape[-2:]), "segmenter": fit.segmenter,
              "fit": {"steps": fit.steps}}
    row["kib"] = save_texture(path, model, fit.textons, fit.labels, fit.generator, header,
                              fit.elements) / 1024
    tex = load_texture(path, model)  # what the CLI sees: fp16 deltas
    decoder, size = tuned_model(model, tex.generator), tuple(image.shape[-2:])
    plain = decoder.generator.feature_channels - 2  # [f_a, d]; detail sprites after
    with torch.no_grad():
        rec = decoder.decode(tex.textons, size)[0]
        start = time.perf_counter()
        shuf, moved, total = swap_and_count(decoder.decode(tex.textons, size)[0], tex.labels,
                                            tex.elements, seed=1)
        row["edit_s"] = time.perf_counter() - start
        shuf_src, _, _ = swap_and_count(image, tex.labels, tex.elements, seed=1,
                                        plan_on=rec)  # reshuffle --source
        shuffled = reshuffle_elements(tex.textons, tex.labels, tex.elements, channels=plain,
                                      seed=1)
        shuf_d = decoder.decode(shuffled, size)[0]
        kinds = texton_kinds(tex.textons, channels=plain)
        shuf_t = decoder.decode(reshuffle(tex.textons, seed=1, kinds=kinds), size)[0]
        rand = decoder.decode(random_placement(tex.textons), size)[0]
    row.update(fit=psnr(rec, image), plain=fit.plain_psnr, ssim_fit=ssim(rec, image),
               swd_rec=swd(image, rec), swd_shuf=swd(image, shuf), swd_shuf_d=swd(image, shuf_d),
               swd_shuf_t=swd(image, shuf_t), moved=moved / max(total, 1),
               swd_rand=swd(image, rand), seconds=fit.seconds + fit.detail_seconds,
               steps=fit.steps, textons=fit.textons.num_textons, segmenter=fit.segmenter,
               change=(shuf - rec).abs().mean().item(), swd_shuf_src=swd(image, shuf_src),
               change_src=(shuf_src - image).abs().mean().item())
    row["_pictures"] = (rec, shuf, shuf_d, shuf_t)
    return row


def procedural_images(count: int) -> list[tuple[str, torch.Tensor]]:
    """The first ``count`` 256 px images of the procedural benchmark split."""
    from neuraltex.data.generator import generate
    from neuraltex.data.splits import benchmark_split

    items = [it for it in benchmark_split() if it.size == 256][:count]
    out = []
    for it in items:
        sample = generate(it.index, it.seed, it.size, it.family)
        image = torch.from_numpy(sample.image).permute(2, 0, 1).contiguous()
        out.append((f"procedural_{it.index}_{sample.family}", image))
    return out


def table(rows: list[tuple[str, dict]]) -> str:
    head = "| image | segmenter | " + " | ".join(COLS) + " |"
    lines = [head, "|" + "---|" * (len(COLS) + 2)]
    for name, r in rows:
        lines.append(f"| {name} | {r.get('segmenter', '')} | "
                     + " | ".join(_fmt(r[c], c) for c in COLS) + " |")
    mean = {c: float(np.mean([r[c] for _, r in rows])) for c in COLS}
    lines.append("| **mean** | | " + " | ".join(_fmt(mean[c], c) for c in COLS) + " |")
    return "\n".join(lines)


def _fmt(x, column: str = "") -> str:
    if column in ("change", "change_src"):
        return f"{x:.3f}"
    if column == "moved":
        return f"{100 * x:.0f} %"
    return f"{x:.0f}" if isinstance(x, int) or abs(x) >= 100 else f"{x:.2f}"


def _named(names: list[str], label: str) -> str:
    """' (label: a, b)' naming the images a count is made of; '' for none."""
    return f" ({label + ': ' if label else ''}{', '.join(names)})" if names else ""


def summary(rows: list[tuple[str, dict]]) -> list[str]:
    r = [row for _, row in rows]
    n = len(r)
    mean = lambda key: float(np.mean([x[key] for x in r]))  # noqa: E731
    over = [name for name, x in rows if x["swd_shuf"] > 1.25 * x["swd_rec"]]
    visible = [name for name, x in rows
               if x["swd_shuf"] <= 1.25 * x["swd_rec"] and x["change"] >= VISIBLE]
    return [
        f"mean PSNR: fit {mean('fit'):.2f} dB (G alone {mean('plain'):.2f}) | flat "
        f"{mean('flat'):.2f} | blur {mean('blur'):.2f} "
        f"| kmeans8 {mean('kmeans8'):.2f}; target blur + 3 = {mean('blur') + 3:.2f}",
        f"fit above flat on {sum(x['fit'] > x['flat'] for x in r)}/{n}, above blur on "
        f"{sum(x['fit'] > x['blur'] for x in r)}/{n}",
        f"reshuffle SWD <= 1.25 x reconstruction SWD on {n - len(over)}/{n}"
        f"{_named(over, 'over')}; below random placement "
        f"on {sum(x['swd_shuf'] < x['swd_rand'] for x in r)}/{n}; below the texton reshuffle on "
        f"{sum(x['swd_shuf'] < x['swd_shuf_t'] for x in r)}/{n} (mean SWD "
        f"{mean('swd_shuf'):.2f} vs {mean('swd_shuf_t'):.2f}; the texton reshuffle is "
        f"<= 1.25 x reconstruction on {sum(x['swd_shuf_t'] <= 1.25 * x['swd_rec'] for x in r)}"
        f"/{n}); mean change {mean('change'):.3f}; elements moved {100 * mean('moved'):.0f} %",
        f"the same elements' textons moved and decoded (previous version): <= 1.25 x "
        f"reconstruction on {sum(x['swd_shuf_d'] <= 1.25 * x['swd_rec'] for x in r)}/{n}, "
        f"mean SWD {mean('swd_shuf_d'):.2f}",
        f"the reshuffle in the source picture (reshuffle --source: the reconstruction's plan "
        f"of moves drawn in the input): <= 1.25 x reconstruction on "
        f"{sum(x['swd_shuf_src'] <= 1.25 * x['swd_rec'] for x in r)}/{n}, below the "
        f"reshuffle in the reconstruction on {sum(x['swd_shuf_src'] < x['swd_shuf'] for x in r)}"
        f"/{n} (mean SWD {mean('swd_shuf_src'):.2f} vs {mean('swd_shuf'):.2f}); mean change "
        f"against the input {mean('change_src'):.3f}",
        f"within 1.25 x and changing the picture (mean |reshuffle - reconstruction| >= "
        f"{VISIBLE}): {len(visible)}/{n}{_named(visible, '')}",
        f"fit seconds mean {mean('seconds'):.1f} (max {max(x['seconds'] for x in r):.1f}); "
        f"texture file {mean('kib'):.0f} KiB (max {max(x['kib'] for x in r):.0f}); reshuffle "
        f"(decode + swap) {mean('edit_s'):.2f} s",
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=55.0,
                    help="whole-fit budget per image (55, the CLI default)")
    ap.add_argument("--steps", type=int, help="fit step budget instead (reproducible)")
    ap.add_argument("--segmenter", default="auto", help="fit --segmenter (default auto)")
    ap.add_argument("--detail", type=int,
                    help="fit --detail: sprite side (default: auto; 0: none)")
    ap.add_argument("--textures", type=Path, default=REAL,
                    help="folder of real textures (default data/real_textures; the held-out "
                    "set: data/real_textures_heldout)")
    ap.add_argument("--limit", type=int, help="only the first N real images")
    ap.add_argument("--only", nargs="+", help="only these real images (names without .png)")
    ap.add_argument("--procedural", type=int, default=0, help="also N procedural images")
    ap.add_argument("--init-compare", type=int, default=0,
                    help="tune the first N images from random weights too, same budget")
    ap.add_argument("--init-chain", type=int, default=0,
                    help="with --init-compare: also start from the shipped G tuned on this "
                    "many procedural textures (training seed) in turn, same budget each")
    ap.add_argument("--init-seeds", type=int, default=1,
                    help="with --init-compare: random initializations to compare with "
                    "(torch seeds 0..N-1; default 1)")
    ap.add_argument("--init-only", action="store_true",
                    help="only the --init-compare runs (no table)")
    ap.add_argument("--weights", type=Path, default=DEFAULT_MODEL,
                    help="model export to fit from, with its fit prior beside it (default: "
                    "the shipped model)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    ap.add_argument("--out", type=Path, help="also write the table (markdown) here")
    ap.add_argument("--pictures", type=Path, help="folder for input|fit|reshuffle PNGs")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    start = time.perf_counter()
    model = load_model(args.weights)
    print(f"start-up (import + load model): {time.perf_counter() - start:.2f} s")
    settings = FitSettings(segmenter=args.segmenter, seconds=None if args.steps else args.seconds,
                           steps=args.steps, detail=args.detail)
    images = [(p.stem, load_image(p)) for p in sorted(args.textures.glob("*.png"))
              if not args.only or p.stem in args.only][:args.limit]
    images += procedural_images(args.procedural)
    if args.init_only:
        print("\n".join(init_compare(images[:args.init_compare], settings, args.init_chain,
                                     args.init_seeds, args.weights)))
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, image in images:
            row = evaluate(model, image, settings, Path(tmp))
            pics = row.pop("_pictures")
            if args.pictures:
                from neuraltex.imageio import save_image

                args.pictures.mkdir(parents=True, exist_ok=True)
                save_image(torch.cat([image, *pics], -1), args.pictures / f"{name}.png")
            rows.append((name, row))
            print(f"{name:24s} {row['segmenter']:12s} fit {row['fit']:.2f} dB (flat "
                  f"{row['flat']:.2f}, blur {row['blur']:.2f}, kmeans8 {row['kmeans8']:.2f}) "
                  f"swd rec/shuf/rand {row['swd_rec']:.1f}/{row['swd_shuf']:.1f}/"
                  f"{row['swd_rand']:.1f} {row['steps']} steps {row['seconds']:.0f} s",
                  flush=True)
        real = [(n, r) for n, r in rows if not n.startswith("procedural_")]
        text = table(rows) + "\n\n" + "\n".join(f"- {s}" for s in summary(real or rows))
        init = init_compare(images[:args.init_compare], settings, args.init_chain,
                            args.init_seeds, args.weights)
        text += "".join(f"\n- {s}" for s in init)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")


def init_compare(images, settings: FitSettings, chain: int = 0, seeds: int = 1,
                 weights: Path = DEFAULT_MODEL) -> list[str]:
    """Where the tuning starts, at the same budget, on ``images``: the shipped weights with
    their fit prior (what ``fit`` does; :mod:`neuraltex.fit_prior`), the shipped G without
    it, and random weights (``seeds`` initializations, torch seeds 0, 1, ...). Prints the
    final PSNRs of G alone, the shipped start's margin over random's mean and best, and how
    soon each start reaches random's mean final PSNR (the tuning's climb, read every
    ``eval_every`` steps; the target: the shipped start wins by 2 dB or gets there 2x sooner).
    With ``chain``, one more start: :func:`chained_model`."""
    if not images:
        return []
    pre = load_model(weights)
    randoms = []
    for seed in range(seeds):
        torch.manual_seed(seed)
        randoms.append(build_model(pre.config).eval())
    chained = chained_model(pre, chain, replace(settings, prior=False)) if chain else None
    plain = replace(settings, prior=False)
    out = []
    for name, image in images:
        (a, ca), (g, cg) = _climb(pre, image, settings), _climb(pre, image, plain)
        rnd = [_climb(m, image, plain) for m in randoms]
        finals = [b.plain_psnr for b, _ in rnd]
        level, mean = sum(finals) / len(finals), _mean_climb([c for _, c in rnd])
        prior = "fit prior" if getattr(pre, "fit_prior", None) is not None else "no fit prior"
        out.append(f"init {name}: shipped ({prior}) {a.plain_psnr:.2f} dB, shipped G alone "
                   f"{g.plain_psnr:.2f} dB, random (seeds 0-{seeds - 1}) "
                   f"{' / '.join(f'{f:.2f}' for f in finals)} dB (mean {level:.2f}) before "
                   f"sprites, {a.steps} steps each ({ca[-1][1]:.0f} / {cg[-1][1]:.0f} / "
                   f"{rnd[0][1][-1][1]:.0f} s); margin over random's mean "
                   f"{a.plain_psnr - level:+.2f} dB, over its best "
                   f"{a.plain_psnr - max(finals):+.2f} dB; random's mean final level: shipped "
                   f"{_sooner(ca, mean, level)}; shipped G alone "
                   f"{_sooner(cg, mean, level)}")
        if chained is not None:
            c, cc = _climb(chained, image, plain)
            out.append(f"init {name}: chained ({chain} procedural) {cc[0][2]:.2f} -> "
                       f"{c.plain_psnr:.2f} dB before sprites; random's mean final level: "
                       f"chained {_sooner(cc, mean, level)}")
    return out


def _mean_climb(curves):
    """The mean of climbs read at the same steps: [(step, seconds, PSNR)]."""
    return [(rows[0][0], sum(r[1] for r in rows) / len(rows), sum(r[2] for r in rows) / len(rows))
            for rows in zip(*curves, strict=False)]


def chained_model(model, count: int, settings: FitSettings):
    """A copy of ``model`` whose G was tuned by ``fit_texture`` (its own regime: segments,
    colour offsets, crops) on ``count`` 256 px procedural textures of training seed 0 in
    turn, each with ``settings``' budget."""
    import copy

    from neuraltex.data.generator import generate

    out = copy.deepcopy(model)
    for i in range(count):
        image = torch.from_numpy(generate(i, 0, 256).image).permute(2, 0, 1).contiguous()
        fit = fit_texture(out, image, replace(settings, detail=0))
        with torch.no_grad():
            for name, p in out.generator.named_parameters():
                p.copy_(fit.generator[name])
    return out


def _climb(model, image, settings: FitSettings):
    """(fit, [(step, seconds, PSNR of G alone)]) of one tuning run."""
    curve = []
    fit = fit_texture(model, image, settings, on_eval=lambda *r: curve.append(r))
    return fit, curve


def _reaches(curve, level: float):
    """First (step, seconds) of ``curve`` at or above ``level`` dB, None if never."""
    return next(((st, sec) for st, sec, p in curve if p >= level - 1e-9), None)


def _sooner(pre, rnd, level: float) -> str:
    """When each climb first reaches ``level`` dB, and how many times sooner the first."""
    a, b = _reaches(pre, level), _reaches(rnd, level)
    say = lambda h: "never" if h is None else f"step {h[0]}"  # noqa: E731
    ratio = f", {b[0] / max(a[0], 1):.1f}x sooner" if a and b else ""
    return f"{say(a)} vs random {say(b)}{ratio}"


if __name__ == "__main__":
    main()
