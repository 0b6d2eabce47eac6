"""Time and peak memory of Gaussian estimation + splatting, forward and backward, on CPU.

    python scripts/bench_splat.py                 # the README table (B=1/8, 64/128/256 px)
    python scripts/bench_splat.py --reference     # the plain-autograd splatting, as baseline

n = 100 Gaussians, 382 appearance + 2 direction channels (the paper's 384). Masks are soft
Voronoi cells of 100 random centres (compact segments, like a trained E_s) unless ``--masks
random`` (softmax of noise: every Gaussian covers the whole image, the worst case for tiling).
Masks and feature maps are at the output resolution unless ``--mask-size`` says otherwise (the
authors' release runs E_s at 128 px and splats at 256 px). Each configuration runs in a fresh
subprocess so its peak RSS (minus the RSS once inputs exist) is its own: "extra MB" is the
memory the computation adds.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import torch


def _rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize() / 2**20


def make_masks(batch: int, n: int, size: int, kind: str, g: torch.Generator) -> torch.Tensor:
    """(B, n, size, size) softmax-normalized masks."""
    from neuraltex.coords import pixel_grid

    if kind == "random":
        return torch.randn(batch, n, size, size, generator=g).softmax(dim=1)
    centres = torch.rand(batch, n, 2, generator=g)
    d2 = torch.cdist(pixel_grid(size, size).expand(batch, -1, -1), centres) ** 2  # (B, HW, n)
    logits = -d2 / (0.1 / n)  # soft cells a few pixels wide at the borders
    return logits.transpose(1, 2).reshape(batch, n, size, size).softmax(dim=1)


def run_one(batch: int, size: int, mask_size: int, n: int, channels: int, masks_kind: str,
            reference: bool, repeats: int) -> dict:
    from neuraltex.estimation import estimate_textons
    from neuraltex.splatting import splat, splat_reference

    render = splat_reference if reference else splat
    g = torch.Generator().manual_seed(0)
    masks = make_masks(batch, n, mask_size, masks_kind, g).requires_grad_(True)
    appearance = torch.randn(batch, channels, mask_size, mask_size, generator=g)
    appearance.requires_grad_(True)
    direction = torch.randn(batch, 2, mask_size, mask_size, generator=g).requires_grad_(True)

    # A dense upstream gradient, as the generator would send back (made once, not timed).
    g_feat = torch.randn(batch, channels + 2, size, size, generator=g)
    g_max = torch.randn(batch, 1, size, size, generator=g)

    def step(backward: bool) -> float:
        t0 = time.perf_counter()
        with torch.set_grad_enabled(backward):
            tex = estimate_textons(masks, appearance, direction, existence="soft")
            out = render(tex, (size, size))
            if backward:
                torch.autograd.backward([out.features, out.max_opacity], [g_feat, g_max])
        return time.perf_counter() - t0

    step(True)  # warm-up (allocator, thread pool)
    masks.grad = appearance.grad = direction.grad = None
    base = _rss_mb()
    peak_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    fwd = min(step(False) for _ in range(repeats))
    both = []
    for _ in range(repeats):
        masks.grad = appearance.grad = direction.grad = None
        both.append(step(True))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"batch": batch, "size": size, "forward_s": fwd, "fwd_bwd_s": min(both),
            "extra_mb": max(peak, peak_before) - base, "threads": torch.get_num_threads()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--reference", action="store_true", help="benchmark splat_reference")
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 8])
    ap.add_argument("--gaussians", type=int, default=100)
    ap.add_argument("--channels", type=int, default=382, help="appearance channels (f)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--masks", choices=["voronoi", "random"], default="voronoi")
    ap.add_argument("--mask-size", type=int, default=0,
                    help="resolution of masks and feature maps (default: the output size)")
    ap.add_argument("--no-thp", action="store_true",
                    help="do not put large tensors on transparent huge pages")
    ap.add_argument("--one", help=argparse.SUPPRESS)  # internal: run one config as JSON
    args = ap.parse_args()

    if args.one:
        b, s = (int(x) for x in args.one.split(","))
        res = run_one(b, s, args.mask_size or s, args.gaussians, args.channels, args.masks,
                      args.reference, args.repeats)
        print(json.dumps(res))
        return

    impl = "splat_reference (autograd)" if args.reference else "splat (chunked, custom backward)"
    masks_at = f"{args.mask_size} px" if args.mask_size else "output size"
    print(f"estimation + {impl}; n={args.gaussians}, C={args.channels}+2, {args.masks} masks "
          f"at {masks_at}, huge pages {'off' if args.no_thp else 'on'}, "
          f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    print(f"{'B':>3} {'size':>9} {'fwd s':>8} {'fwd+bwd s':>10} {'extra MB':>9}")
    for b in args.batches:
        for s in args.sizes:
            cmd = [sys.executable, __file__, "--one", f"{b},{s}", "--repeats", str(args.repeats),
                   "--gaussians", str(args.gaussians), "--channels", str(args.channels),
                   "--masks", args.masks, "--mask-size", str(args.mask_size)]
            if args.reference:
                cmd.append("--reference")
            env = {**os.environ, "THP_MEM_ALLOC_ENABLE": "0" if args.no_thp else "1"}
            proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
            if proc.returncode != 0:
                print(f"{b:>3} {s:>4}x{s:<4} failed: {proc.stderr.strip().splitlines()[-1]}")
                continue
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            print(f"{b:>3} {s:>4}x{s:<4} {r['forward_s']:>8.3f} {r['fwd_bwd_s']:>10.3f} "
                  f"{r['extra_mb']:>9.0f}")


if __name__ == "__main__":
    main()
