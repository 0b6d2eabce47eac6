"""Time and peak memory of Gaussian estimation + splatting, forward and backward, on CPU.

    python scripts/bench_splat.py                 # the README table (B=1/8, 64/128/256 px)
    python scripts/bench_splat.py --reference     # the plain-autograd splatting, as baseline

n = 100 Gaussians, 382 appearance + 2 direction channels (the paper's 384), masks and feature
maps at the output resolution. Each configuration runs in a fresh subprocess so its peak RSS
(minus the RSS once inputs exist) is its own: "extra MB" is the memory the computation adds.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import torch


def _rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize() / 2**20


def run_one(batch: int, size: int, n: int, channels: int, reference: bool, repeats: int) -> dict:
    from neuraltex.estimation import estimate_textons
    from neuraltex.splatting import splat, splat_reference

    render = splat_reference if reference else splat
    g = torch.Generator().manual_seed(0)
    logits = torch.randn(batch, n, size, size, generator=g)
    masks = logits.softmax(dim=1).requires_grad_(True)
    appearance = torch.randn(batch, channels, size, size, generator=g).requires_grad_(True)
    direction = torch.randn(batch, 2, size, size, generator=g).requires_grad_(True)

    def step(backward: bool) -> float:
        t0 = time.perf_counter()
        with torch.set_grad_enabled(backward):
            tex = estimate_textons(masks, appearance, direction, existence="soft")
            out = render(tex, (size, size))
            if backward:
                (out.features.square().mean() + out.max_opacity.mean()).backward()
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
    ap.add_argument("--one", help=argparse.SUPPRESS)  # internal: run one config as JSON
    args = ap.parse_args()

    if args.one:
        b, s = (int(x) for x in args.one.split(","))
        res = run_one(b, s, args.gaussians, args.channels, args.reference, args.repeats)
        print(json.dumps(res))
        return

    impl = "splat_reference (autograd)" if args.reference else "splat (chunked, custom backward)"
    print(f"estimation + {impl}; n={args.gaussians}, C={args.channels}+2, "
          f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    print(f"{'B':>3} {'size':>9} {'fwd s':>8} {'fwd+bwd s':>10} {'extra MB':>9}")
    for b in args.batches:
        for s in args.sizes:
            cmd = [sys.executable, __file__, "--one", f"{b},{s}", "--repeats", str(args.repeats),
                   "--gaussians", str(args.gaussians), "--channels", str(args.channels)]
            if args.reference:
                cmd.append("--reference")
            proc = subprocess.run(cmd, capture_output=True, text=True)
            if proc.returncode != 0:
                print(f"{b:>3} {s:>4}x{s:<4} failed: {proc.stderr.strip().splitlines()[-1]}")
                continue
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            print(f"{b:>3} {s:>4}x{s:<4} {r['forward_s']:>8.3f} {r['fwd_bwd_s']:>10.3f} "
                  f"{r['extra_mb']:>9.0f}")


if __name__ == "__main__":
    main()
