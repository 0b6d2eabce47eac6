"""Curve synthesis speed: seconds for outputs of about ``--target`` finest samples, and for
autocomplete of a local region, on 1 torch thread: wall and CPU seconds (process time; on a
loaded machine wall is about CPU x load / cores). The seed reports ~160 s for ~1,000 output
samples on 16 cores (its C++); the issue's targets are <= 30 s and <= 2 s on 2 cores.

    python scripts/bench_curves.py [--target 1000] [--edge-term matching] [NAME ...]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import torch

from cvt.curves.autocomplete import autocomplete
from cvt.curves.baselines import run_curves
from cvt.curves.sampling import exemplar_graph
from cvt.curves.strokes import curve_exemplar, load_curves
from cvt.curves.synthesis import CurveConfig
from cvt.svg import parse_svg

EXEMPLARS = Path(__file__).resolve().parents[1] / "cvt" / "exemplars" / "curves"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=["waves", "lace", "vines", "voronoi", "spirals"],
                    help="shipped curve exemplar names")
    ap.add_argument("--target", type=int, default=1000, help="finest output samples wanted")
    ap.add_argument("--edge-term", choices=("embedding", "matching"), default="embedding",
                    help="eq. 5 as the direction embedding (default) or the per-pair matching")
    args = ap.parse_args()
    missing = [n for n in args.names if not (EXEMPLARS / f"{n}.svg").exists()]
    if missing:
        ap.error(f"no shipped curve exemplar named {', '.join(missing)}")
    torch.set_num_threads(1)
    cfg = CurveConfig(edge_term=args.edge_term)
    print("| exemplar | output size | samples | synthesis s | CPU s | autocomplete s | CPU s |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for name in args.names:
        cx = load_curves(EXEMPLARS / f"{name}.svg")
        w, h = cx.exemplar.viewbox[2:]
        pos = exemplar_graph(cx, cfg.level(cx.exemplar.size, cfg.levels - 1).delta).pos
        x0, y0, x1, y1 = cx.box  # strokes may run past the viewBox: count what shows
        n_in = int(((pos[:, 0] >= x0) & (pos[:, 0] <= x1) & (pos[:, 1] >= y0)
                    & (pos[:, 1] <= y1)).sum())
        scale = math.sqrt(args.target / n_in)
        t, c = time.perf_counter(), time.process_time()
        g, _ = run_curves("ours", cx, (scale * w, scale * h), cfg)
        synth, synth_cpu = time.perf_counter() - t, time.process_time() - c
        # autocomplete: the exemplar's left half as the drawing, its right half predicted
        half = [s for s in cx.strokes if s.points[:, 0].max() < w / 2]
        drawn = curve_exemplar(parse_svg(EXEMPLARS.joinpath(f"{name}.svg").read_bytes()))
        drawn.strokes = half or cx.strokes[:1]
        t, c = time.perf_counter(), time.process_time()
        autocomplete(cx, drawn, (w / 2 - 10, 0, w / 2 + w / 4, h / 2),
                     CurveConfig(levels=2, edge_term=args.edge_term))
        ac, ac_cpu = time.perf_counter() - t, time.process_time() - c
        print(f"| {name} | {scale * w:.0f} x {scale * h:.0f} | {len(g)} | {synth:.1f} | "
              f"{synth_cpu:.1f} | {ac:.2f} | {ac_cpu:.2f} |", flush=True)
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
