"""What a trained model does beyond segmentation (the default-model targets), on held-out
benchmark images:

    python scripts/eval_model.py                          # the shipped model
    python scripts/eval_model.py --checkpoint runs/x/model.safetensors --limit 40

- reconstruction PSNR at 128 x 128, beside two references: a constant mean-colour image, and
  the model's own E_s masks painted with their mean input colours (what a flat-colour decoder
  of the same segmentation reaches: the gap is the decoder's);
- cycle consistency CC (seed 003, eq. 4.32): L_csis between edited textons g* and the textons
  re-extracted from their decoding E(G(g*)), for no edit (R) and random translate / rotate /
  scale edits. Textons have no segmentation masks after an edit, so the mask term of eq. 4.21
  compares composited splat weights (eq. 4.13) on both sides; the sum over matches is
  averaged over the effective textons of g*;
- shift equivariance: textons of a 128 px window and of the window moved by (dx, dy) pixels,
  matched by the Hungarian algorithm on their centres; the mean centre error in pixels after
  undoing the shift (interior textons only, matches within 8 px; the matched fraction too);
- reshuffle invariance: patch sliced-Wasserstein distance (neuraltex.losses) between the input
  and its reshuffled reconstruction, next to the same distance for the plain reconstruction;
  the reshuffle of the seed (every effective texton's features permuted) and the one
  ``neuraltex reshuffle`` makes of an image (features permuted within texton kinds, the
  background layer keeping its own).

Segmentation scores (matched mIoU, count error) come from scripts/eval_textons.py.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from scipy.optimize import linear_sum_assignment
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuraltex.data.generator import generate  # noqa: E402
from neuraltex.data.splits import benchmark_split  # noqa: E402
from neuraltex.errors import cli_entry  # noqa: E402
from neuraltex.fileio import write_text_atomic  # noqa: E402
from neuraltex.losses import sliced_wasserstein_patches  # noqa: E402
from neuraltex.reshuffle import reshuffle  # noqa: E402
from neuraltex.splatting import opacity_maps  # noqa: E402
from neuraltex.texton_kinds import texton_kinds  # noqa: E402
from train.consistency import ConsistencyWeights, matching_cost  # noqa: E402

SIZE = 128
EDITS = {"R": None, "translate": ("translate", 0.15), "rotate": ("rotate", 30.0),
         "scale": ("scale", 1.25)}


def psnr(x: torch.Tensor, y: torch.Tensor) -> float:
    mse = float((x - y).square().mean())
    return 10 * np.log10(1.0 / max(mse, 1e-12))


def mask_colours(masks: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
    """Each E_s mask painted with the mean input colour under it: masks (B, n, h, w), x (B, 3,
    H, W) -> (B, 3, H, W). The reference for G: what a flat-colour decoder of the same
    segmentation reaches."""
    S = F.interpolate(masks, size=tuple(x.shape[-2:]), mode="bilinear", align_corners=False)
    colour = torch.einsum("bnhw,bchw->bnc", S, x) / S.sum(dim=(2, 3)).clamp_min(1e-6)[..., None]
    return torch.einsum("bnhw,bnc->bchw", S, colour)


def _edit(z, edit, rng: np.random.Generator):
    if edit is None:
        return z
    kind, amount = edit
    if kind == "translate":
        a = rng.uniform(0, 2 * np.pi)
        return z.translate(amount * np.cos(a), amount * np.sin(a))
    if kind == "rotate":
        return z.rotate(float(rng.choice([-1, 1]) * amount))
    return z.scale(amount if rng.random() < 0.5 else 1 / amount)


def cycle_consistency(model, z, size) -> float:
    """eq. 4.32 for one image (B = 1)."""
    z2 = model.encode(model.decode(z, size)).textons
    keep = z.p[0] > 0.5
    if not keep.any():
        return float("nan")
    za = z.index(torch.nonzero(keep).squeeze(1)[None])
    small = (size[0] // 2, size[1] // 2)
    wa = opacity_maps(za, small, cutoff=model.cutoff)
    wb = opacity_maps(z2, small, cutoff=model.cutoff)
    cost = matching_cost(za, z2, wa, wb, ConsistencyWeights())[0]
    r, c = linear_sum_assignment(cost.numpy())
    return float(cost[r, c].sum()) / len(r)


def shift_error(model, image: np.ndarray, dx: int, dy: int, margin: int = 16,
                gate: float = 8.0) -> tuple[float, float]:
    """(mean centre error in px, matched fraction) between a window and the shifted one."""
    x = torch.from_numpy(image).permute(2, 0, 1).float()
    a = x[:, :SIZE, :SIZE]
    b = x[:, dy:dy + SIZE, dx:dx + SIZE]
    ta, tb = (model.encode(w[None]).textons for w in (a, b))
    ca = ta.mu[0][ta.p[0] > 0.5] * SIZE - torch.tensor([dx, dy])  # into b's pixel frame
    cb = tb.mu[0][tb.p[0] > 0.5] * SIZE

    def interior(c):
        return c[((c > margin) & (c < SIZE - margin)).all(-1)]

    ca, cb = interior(ca), interior(cb)
    if len(ca) == 0 or len(cb) == 0:
        return float("nan"), 0.0
    d = torch.cdist(ca, cb).numpy()
    r, c = linear_sum_assignment(d)
    good = d[r, c] < gate
    if not good.any():
        return float("nan"), 0.0
    return float(d[r, c][good].mean()), float(good.sum() / max(len(ca), len(cb)))


def evaluate(model, limit: int | None, progress: bool = True) -> dict:
    items = [it for it in benchmark_split() if it.size == SIZE][:limit]
    rng = np.random.default_rng(0)
    rows = []
    for it in tqdm(items, desc="eval", disable=not progress):
        s = it.load()
        x = torch.from_numpy(s.image).permute(2, 0, 1).float()[None]
        row = {"family": s.family}
        enc = model.encode(x)
        recon = model.decode(enc.textons, (SIZE, SIZE))
        row["psnr"] = psnr(recon, x)
        row["psnr_constant"] = psnr(x.mean(dim=(2, 3), keepdim=True).expand_as(x), x)
        row["psnr_mask_colours"] = psnr(mask_colours(enc.masks, x), x)
        for name, edit in EDITS.items():
            row[f"cc_{name}"] = cycle_consistency(model, _edit(enc.textons, edit, rng),
                                                  (SIZE, SIZE))
        kinds = texton_kinds(enc.textons, channels=model.generator.feature_channels - 2)
        for key, shuffled in (("swd_recon", recon), ("swd_reshuffled", _reshuffled(
                model, enc.textons, it.index)), ("swd_reshuffled_kinds", _reshuffled(
                model, enc.textons, it.index, kinds))):
            g = torch.Generator().manual_seed(0)
            row[key] = float(sliced_wasserstein_patches(shuffled, x, patch=4, generator=g))
        big = generate(it.index, it.seed, SIZE * 2, family=it.family).image  # same texture
        row["shift_err_px"], row["shift_matched"] = shift_error(model, big, 8, 5)
        rows.append(row)
    keys = [k for k in rows[0] if k != "family"]
    return {"images": len(rows), "mean": {k: _mean([r[k] for r in rows]) for k in keys},
            "rows": rows}


def _mean(values: list[float]) -> float:
    """The mean of the numbers that are not nan; nan (without numpy's warning) if none is."""
    finite = [v for v in values if not np.isnan(v)]
    return float(np.mean(finite)) if finite else float("nan")


def _reshuffled(model, textons, seed: int, kinds=None):
    """Decode of a reshuffle (128 px): every effective texton's features permuted (the seed's
    4.4.1), or only within kinds, the background layer keeping its own (``kinds``: what
    ``neuraltex reshuffle`` does with an image)."""
    return model.decode(reshuffle(textons, seed=seed, kinds=kinds), (SIZE, SIZE))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="eval_model", description=__doc__.split("\n")[0])
    p.add_argument("--checkpoint", default=None, help="model .safetensors (default: shipped)")
    p.add_argument("--limit", type=int, default=None, help="first N 128 px benchmark images")
    p.add_argument("--json", default=None, help="write per-image numbers to this file")
    p.add_argument("--threads", type=int, default=None, help="torch threads")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


@cli_entry("eval_model")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from neuraltex.model import DEFAULT_MODEL, load_model

    if args.threads:
        torch.set_num_threads(args.threads)
    model = load_model(args.checkpoint or DEFAULT_MODEL)
    with torch.no_grad():
        res = evaluate(model, args.limit, progress=not args.quiet)
    m = res["mean"]
    print(f"{res['images']} held-out benchmark images at {SIZE} px")
    print(f"reconstruction PSNR {m['psnr']:.2f} dB (constant mean colour: "
          f"{m['psnr_constant']:.2f} dB; the E_s masks painted with their mean colours: "
          f"{m['psnr_mask_colours']:.2f} dB)")
    print("cycle consistency CC: " + ", ".join(f"{k} {m[f'cc_{k}']:.3f}" for k in EDITS))
    print(f"shift (8, 5) px: mean centre error {m['shift_err_px']:.2f} px, "
          f"{100 * m['shift_matched']:.0f}% of textons matched within 8 px")
    print(f"patch SWD to the input: reconstruction {m['swd_recon']:.4f}, reshuffled "
          f"{m['swd_reshuffled']:.4f} (difference {m['swd_reshuffled'] - m['swd_recon']:+.4f}); "
          f"within kinds, as `neuraltex reshuffle` does, {m['swd_reshuffled_kinds']:.4f} "
          f"({m['swd_reshuffled_kinds'] - m['swd_recon']:+.4f})")
    if args.json:
        write_text_atomic(args.json, json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
