"""Print parameter counts and CPU forward latency of every network for each preset.

    python scripts/count_params.py                  # tiny, small, paper at 128^2, batch 1
    python scripts/count_params.py --presets tiny --size 64 --threads 2

Latency: eval mode, no grad, one warm-up run (skipped for paper, which is slow) then one timed
run. The generator is timed on a random F_s (B, C_a+2, S, S) and F_max (B, 1, S, S); D_p on the
8 crops of one image (crop size from the preset).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from neuraltex.discriminators import random_crops  # noqa: E402
from neuraltex.networks import PRESETS, NetworksConfig, build_networks  # noqa: E402


def timed(fn, warmup: bool) -> float:
    with torch.no_grad():
        if warmup:
            fn()
        t = time.perf_counter()
        fn()
        return time.perf_counter() - t


def report(preset: str, size: int) -> None:
    torch.manual_seed(0)
    cfg = NetworksConfig.preset(preset)
    nets = build_networks(cfg).eval()
    counts = nets.parameter_counts()
    c = nets.generator.feature_channels
    img = torch.rand(1, 3, size, size)
    f_s, f_max = torch.rand(1, c, size, size), torch.rand(1, 1, size, size)
    pd = cfg.patch_discriminator
    crops = random_crops(img, min(size, pd.crop_size), pd.num_crops)  # (8, 3, s, s)
    calls = {
        "encoder": lambda: nets.encoder(img),
        "segmentation": lambda: nets.segmentation(img),
        "generator": lambda: nets.generator(f_s, f_max),
        "discriminator": lambda: nets.discriminator(img),
        "patch_discriminator": lambda: nets.patch_discriminator(crops, crops),
    }
    warm = preset != "paper"
    print(f"\n[{preset}] {size}x{size}, batch 1, {torch.get_num_threads()} thread(s)")
    print(f"  {'network':<20} {'params':>12} {'forward ms':>11}")
    for name, fn in calls.items():
        ms = 1000 * timed(fn, warm)
        print(f"  {name:<20} {counts[name]:>12,} {ms:>11.1f}")
    print(f"  {'total':<20} {counts['total']:>12,}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", nargs="+", default=list(PRESETS), choices=PRESETS)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--threads", type=int, default=None, help="torch CPU threads")
    args = ap.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    for preset in args.presets:
        report(preset, args.size)


if __name__ == "__main__":
    main()
