"""Benchmark cvt synthesis: per-step times and samples per level for the shipped exemplars.

    python scripts/bench_cvt.py                       # every exemplar at 2x size
    python scripts/bench_cvt.py --target 4500 stars   # size chosen for ~4,500 finest samples
    python scripts/bench_cvt.py --profile stars       # plus a cProfile of the slowest run

Prints a Markdown table. Times are wall-clock seconds of one run (3 levels x 7 iterations by
default) on this machine; set --threads to the cores you can actually use. The clustering
share is the clustering step's part of each level's time (seed 000 Table 2: ~10-25 %).
"""

from __future__ import annotations

import argparse
import cProfile
import io
import math
import pstats
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cvt.baselines import METHODS, method_config  # noqa: E402
from cvt.sampling import sample_exemplar  # noqa: E402
from cvt.svg import load_svg  # noqa: E402
from cvt.synthesis import STEPS, SynthesisConfig, synthesize  # noqa: E402


def _scale_for(ex, target: int, cfg: SynthesisConfig) -> float:
    """Output scale that gives about ``target`` finest-level samples."""
    n = len(sample_exemplar(ex, cfg.deltas[-1] * ex.size))
    return math.sqrt(target / max(n, 1))


def bench_one(path: Path, scale: float | None, target: int | None, cfg: SynthesisConfig,
              profile: bool = False):
    ex = load_svg(path)
    s = scale if target is None else _scale_for(ex, target, cfg)
    size = (ex.viewbox[2] * s, ex.viewbox[3] * s)
    prof = cProfile.Profile() if profile else None
    t = time.perf_counter()
    if prof:
        prof.enable()
    res = synthesize(ex, size, cfg)
    if prof:
        prof.disable()
    total = time.perf_counter() - t
    return ex, s, res, total, prof


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="exemplar names (default: all shipped)")
    ap.add_argument("--scale", type=float, default=2.0)
    ap.add_argument("--target", type=int, help="pick the scale for this many finest samples")
    ap.add_argument("--levels", type=int, default=3)
    ap.add_argument("--iterations", type=int, default=7)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--method", choices=[m for m in METHODS if m != "random"], default="full")
    ap.add_argument("--profile", action="store_true", help="cProfile the slowest run")
    args = ap.parse_args()
    folder = ROOT / "cvt" / "exemplars"
    paths = [folder / f"{n}.svg" for n in args.names] or sorted(folder.glob("*.svg"))
    cfg = method_config(args.method, SynthesisConfig(levels=args.levels,
                                                     iterations=args.iterations, seed=args.seed,
                                                     threads=args.threads))
    head = ["exemplar", "scale", "elements in/out", "samples per level (out)"]
    head += [f"{s} s" for s in STEPS] + ["total s", "clustering share per level",
                                          "final energy"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    worst = None
    for p in paths:
        ex, s, res, total, prof = bench_one(p, args.scale, args.target, cfg, args.profile)
        row = [p.stem, f"{s:.2f}", f"{len(ex.elements)}/{len(res.placements)}",
               " / ".join(map(str, res.samples_per_level))]
        share = " / ".join(f"{100 * t['clustering'] / max(sum(t.values()), 1e-9):.0f} %"
                           for t in res.level_timings)
        row += [f"{res.timings[k]:.2f}" for k in STEPS] + [f"{total:.2f}", share,
                                                           f"{res.energies[-1][2]:.2f}"]
        print("| " + " | ".join(row) + " |", flush=True)
        if prof and (worst is None or total > worst[0]):
            worst = (total, p.stem, prof)
    if worst:
        buf = io.StringIO()
        pstats.Stats(worst[2], stream=buf).sort_stats("tottime").print_stats(15)
        print(f"\nprofile of {worst[1]} ({worst[0]:.1f} s), by own time:\n{buf.getvalue()}")


if __name__ == "__main__":
    main()
