"""Curve synthesis benchmark: graph statistics, curvature / segment-length distributions and
patch-SWD of every shipped curve exemplar against its syntheses by ours, the issue's
no-connectivity baseline (nearest-neighbour reconnection, no end repair), the same baseline
with ours' whole finish, and random placement of exemplar pieces (cvt.curves.baselines).

    python scripts/eval_curves.py [--scale 1.5] [--out docs/curves_eval.md] [NAME ...]
    python scripts/eval_curves.py --real [--out docs/curves_eval_real.md]   # data/real_curves

Outputs are read back from their SVG and sampled at the finest spacing, like the exemplar
(cvt.curves.stats). Targets: degree TV, end-density relative error and curvature TV
<= 0.15, and better than no-connectivity (the issue's baseline), on >= 80 % of the exemplars;
the verdicts against no-connectivity+finish are printed beside them.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from cvt.curves.baselines import METHODS, CurveRun, run_staged
from cvt.curves.ends import CAP_REACH, capped_ends
from cvt.curves.graph import CurveGraph
from cvt.curves.reconstruction import curves_svg
from cvt.curves.sampling import exemplar_graph
from cvt.curves.stats import compare, graph_stats
from cvt.curves.strokes import curve_exemplar, load_curves
from cvt.curves.synthesis import CurveConfig
from cvt.metrics import patch_swd
from cvt.raster import render_svg
from cvt.svg import parse_svg
from neuraltex.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
EXEMPLARS = ROOT / "cvt" / "exemplars" / "curves"
REAL = ROOT / "data" / "real_curves"  # third-party stroke art (SOURCES.md there)
KEYS = ("degree_tv", "ends_rel", "curvature_tv", "junctions_rel", "loops_rel", "segments_tv")
TARGET = ("degree_tv", "ends_rel", "curvature_tv")
BASE, STRONG = "no-connectivity", "no-connectivity+finish"
ROWS = {"ours": "ours", BASE: BASE, STRONG: BASE, "random": "random"}  # row -> method run
NOTES = """Rules (cvt.curves.stats; the same for the exemplar and every output): every SVG is
read back and sampled at the finest spacing delta; only samples more than 2 delta inside the
canvas count, so path ends made by the canvas border (the waves' line ends, cut strokes of a
crop) are not counted for the exemplar nor for any output. End density: interior ends per 100
counted samples, relative error with a floor of 1 per 100. Curvature: turning angle per length
times delta at degree-2 samples, 13 soft bins (linear binning between centres 0.05 ... 1.25),
total variation.

Methods: ours is what a user gets (synthesis with connectivity, then the finish
cvt.curves.baselines.finish: redrawn at delta, spurs / specks pruned, stroke ends repaired
toward the exemplar's end density, faired). no-connectivity is the issue's baseline: the same
synthesis without the edge term and edge assignment, samples reconnected to their nearest
neighbours, redrawn at delta and faired like ours (CurveRun.plain) -- no pruning, no end
repair. no-connectivity+finish is the same synthesis run with ours' whole finish (a stronger
baseline: the end repair moves its end density toward the exemplar's too); the targets are
stated against no-connectivity, the verdicts against no-connectivity+finish are printed beside
them. random: exemplar pieces on a grid, with the finish. The "before" columns
(cvt.curves.baselines.CurveRun.raw) show what each synthesis achieves alone."""


def read_graph(svg: str, delta: float) -> CurveGraph:
    try:
        return exemplar_graph(curve_exemplar(parse_svg(svg.encode())), delta)
    except InputError:  # nothing left to draw
        return CurveGraph.empty([])


def measure(svg: str, box, delta: float):
    return graph_stats(read_graph(svg, delta), box, delta)


def capped_share(svg: str, box, delta: float) -> list[int]:
    """[interior stroke ends, those with a discrete element at them (a circuit's pad)]."""
    g = read_graph(svg, delta)
    x0, y0, x1, y1 = box
    p, m = g.pos, 2 * delta
    inner = ((p[:, 0] > x0 + m) & (p[:, 0] < x1 - m) & (p[:, 1] > y0 + m) & (p[:, 1] < y1 - m)
             & (g.kind < 0)).numpy()
    ends = inner & (g.degree().numpy() == 1)
    return [int(ends.sum()), int((ends & capped_ends(g, CAP_REACH * delta)).sum())]


def evaluate(path: Path, scale: float, out_dir: Path | None, cfg: CurveConfig,
             methods=METHODS) -> dict:
    name = path.stem
    cx = load_curves(path)
    x, y, w, h = cx.exemplar.viewbox
    size = (scale * w, scale * h)
    seed = cfg.seed
    delta = cfg.level(cx.exemplar.size, cfg.levels - 1).delta
    ref = measure(path.read_text(), cx.box, delta)
    ref_img = render_svg(path.read_text())
    row = {"exemplar": name, "samples_in": ref.samples, "ends_in": ref.ends,
           "degree_in": ref.degree.tolist(), "capped_in": capped_share(path.read_text(), cx.box,
                                                                      delta)}
    out_box = (x, y, x + size[0], y + size[1])
    for method in methods:
        t = time.perf_counter()
        run = run_staged(method, cx, size, cfg)
        seconds = time.perf_counter() - t
        pre = measure(curves_svg(cx.exemplar, cx.element_centers(), run.raw, size), out_box, delta)
        raw = {**compare(pre, ref), "ends": pre.ends, "degree": pre.degree.tolist()}
        for key in (k for k, m in ROWS.items() if m == method):
            g = output_of(key, run)
            svg = curves_svg(cx.exemplar, cx.element_centers(), g, size)
            if out_dir is not None:
                (out_dir / f"{name}.{key}.svg").write_text(svg)
            st = measure(svg, out_box, delta)
            row[key] = {**compare(st, ref), "swd": patch_swd(render_svg(svg), ref_img, seed),
                        "seconds": seconds, "samples": len(g), "ends": st.ends,
                        "degree": st.degree.tolist(), "raw": raw,
                        "capped": capped_share(svg, out_box, delta)}
    return row


def output_of(key: str, run: CurveRun):
    """The issue's baseline is the reconnected synthesis only faired; every other row (ours
    included) is the output after the whole finish."""
    return run.plain if key == BASE else run.final


def _pct(h) -> str:
    return "/".join(f"{100 * v:.0f}" for v in h)


def verdict(rows: list[dict], key: str, stage, base: str = BASE) -> str:
    """Ours against ``base`` on ``key`` of ``stage(row[method])``: within, better, tied (and
    how many ties are both exact), worse."""
    n = len(rows)
    a = [stage(r["ours"])[key] for r in rows]
    b = [stage(r[base])[key] for r in rows]
    better = sum(x < y for x, y in zip(a, b, strict=True))
    tied = sum(x == y for x, y in zip(a, b, strict=True))
    exact = sum(x == y == 0 for x, y in zip(a, b, strict=True))
    return (f"ours within 0.15 on {sum(x <= 0.15 for x in a)}/{n}, better than "
            f"{base} on {better}/{n}, tied on {tied} ({exact} of them both exactly "
            f"the exemplar's value, error 0), worse on {n - better - tied}")


def no_end_lines(rows: list[dict]) -> list[str]:
    """Exemplars without interior ends: which methods reach exactly 0 ends."""
    zero = [r for r in rows if r["ends_in"] == 0]
    if not zero:
        return []
    out = []
    for label, stage in (("before the end repair", lambda v: v["raw"]), ("after it", lambda v: v)):
        hits = {m: [r["exemplar"] for r in zero if stage(r[m])["ends"] == 0] for m in ROWS}
        names = ", ".join(r["exemplar"] for r in zero)
        got = "; ".join(f"{m} {len(h)} ({', '.join(h)})" for m, h in hits.items())
        out.append(f"- exemplars without ends ({len(zero)}: {names}), 0 ends {label}: {got}")
    return out


def capped_lines(rows: list[dict]) -> list[str]:
    """Exemplars whose stroke ends carry a discrete element: how many output ends do."""
    out = []
    for r in rows:
        n, c = r["capped_in"]
        if c:
            got = "; ".join(f"{m} {r[m]['capped'][1]} of {r[m]['capped'][0]}" for m in ROWS)
            out.append(f"- {r['exemplar']}: interior ends with an element at them (within "
                       f"{CAP_REACH:g} delta): exemplar {c} of {n}; {got}")
    return out


def summary(rows: list[dict]) -> list[str]:
    lines = ["", "| method | " + " | ".join(KEYS) + " | swd | s |", "|---" * (len(KEYS) + 3) + "|"]
    for method in ROWS:
        med = [np.median([r[method][k] for r in rows]) for k in (*KEYS, "swd", "seconds")]
        lines.append(f"| {method} (median) | " + " | ".join(f"{v:.3f}" for v in med) + " |")
    lines.append("")
    for k in ("degree_tv", "ends_rel"):
        lines.append(f"- {k} before the end repair: " + verdict(rows, k, lambda v: v["raw"]))
    lines += ["", "Targets (against the issue's baseline, no-connectivity):"]
    lines += [f"- {k}: " + verdict(rows, k, lambda v: v) for k in TARGET]
    lines += ["", "Beside them, against the stronger no-connectivity+finish:"]
    lines += [f"- {k}: " + verdict(rows, k, lambda v: v, STRONG) for k in TARGET]
    return lines + no_end_lines(rows) + capped_lines(rows) + ["", NOTES]


def stages_table(rows: list[dict]) -> list[str]:
    """End density and degree histogram of every method before and after the end repair."""
    head = ("| exemplar | method | before: ends/100 | ends_rel | degree 1/2/3/4+ % | degree_tv "
            "| after: ends/100 | ends_rel | degree 1/2/3/4+ % | degree_tv |")
    lines = [head, "|---" * 10 + "|"]
    for r in rows:
        ex = f"{r['ends_in']:.2f} | | {_pct(r['degree_in'])} |"
        lines.append(f"| {r['exemplar']} | exemplar | {ex} | {ex} |")
        for method in ROWS:
            v, w = r[method]["raw"], r[method]
            lines.append(f"| {r['exemplar']} | {method} | "
                         + " | ".join(f"{x['ends']:.2f} | {x['ends_rel']:.3f} | "
                                      f"{_pct(x['degree'])} | {x['degree_tv']:.3f}"
                                      for x in (v, w)) + " |")
    return lines


def table(rows: list[dict]) -> list[str]:
    head = "| exemplar | method | " + " | ".join(KEYS) + " | swd | samples | s |"
    lines = [head, "|---" * (len(KEYS) + 5) + "|"]
    for r in rows:
        for method in ROWS:
            v = r[method]
            lines.append(f"| {r['exemplar']} | {method} | "
                         + " | ".join(f"{v[k]:.3f}" for k in KEYS)
                         + f" | {v['swd']:.1f} | {v['samples']} | {v['seconds']:.1f} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="exemplar names (default: all shipped)")
    ap.add_argument("--scale", type=float, default=1.5, help="output side / exemplar side")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--real", action="store_true",
                    help="the real stroke art of data/real_curves instead of the shipped exemplars")
    ap.add_argument("--out", type=Path, help="write the markdown table here (and .json)")
    ap.add_argument("--svg-dir", type=Path, help="keep the output SVGs here")
    ap.add_argument("--only", choices=METHODS, help="run one method (no summary table)")
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                    help="CurveConfig overrides, e.g. --set iterations=10 c_out=3")
    args = ap.parse_args()
    over = {k: type(getattr(CurveConfig, k))(v) for k, v in (a.split("=") for a in args.set)}
    cfg = CurveConfig(seed=args.seed, **over)
    methods = (args.only,) if args.only else METHODS
    shown = [k for k, m in ROWS.items() if m in methods]
    torch.set_num_threads(1)
    folder = REAL if args.real else EXEMPLARS
    names = args.names or sorted(p.stem for p in folder.glob("*.svg"))
    if args.svg_dir:
        args.svg_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in names:
        rows.append(evaluate(folder / f"{name}.svg", args.scale, args.svg_dir, cfg, methods))
        print(" | ".join(f"{m}: " + " ".join(f"{rows[-1][m][k]:.2f}" for k in TARGET)
                         + f" (raw ends {rows[-1][m]['raw']['ends_rel']:.2f})"
                         + f" {rows[-1][m]['seconds']:.1f}s" for m in shown), "<-", name,
              flush=True)
    if args.only:
        for key in shown:
            for k in TARGET:
                print(key, k, "median", np.median([r[key][k] for r in rows]), "within 0.15:",
                      sum(r[key][k] <= 0.15 for r in rows), "/", len(rows))
        return
    text = "\n".join(["Outputs (ours: what the user gets; methods below the tables):", "",
                      *table(rows), "",
                      "End density and degree histogram before the end repair (the synthesis "
                      "itself, redrawn at delta; nothing pruned, joined or removed) and of the "
                      "output above:", "", *stages_table(rows), *summary(rows)]) + "\n"
    print(text)
    if args.out:
        real = " --real" if args.real else ""
        args.out.write_text(f"Curve synthesis benchmark (`python scripts/eval_curves.py{real} "
                            f"--scale {args.scale:g}`), seed {args.seed}.\n\n" + text)
        args.out.with_suffix(".json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
