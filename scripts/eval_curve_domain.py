"""Curve synthesis into a domain shape (``cvt synthesize --domain``): how the strokes meet the
domain's border with eq. 15's pull (seed 001: samples leaving the domain are pulled back toward
its border) against dropping the samples that leave it (``--set domain_pull=0``).

    python scripts/eval_curve_domain.py [--out docs/curves_domain.md] [NAME ...]

Each shipped exemplar is synthesized at 1.5x into a disk (radius 0.45 of the output side) by
ours (what a user gets, the finish included) both ways, seed 0. Printed per output, from the
final graph at the finest spacing delta: samples per unit area in the band within 2 delta of
the border relative to the interior's (1: the border is as full as the inside; dropping
leaves it thinner), stroke ends per 100 samples in the band and inside, pieces of fewer than
6 samples touching the band (stroke bits cut off by the border), samples outside (0), and
seconds.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from cvt.cli_curves import domain_inside
from cvt.curves.baselines import run_curves
from cvt.curves.domain import Domain
from cvt.curves.graph import CurveGraph, components
from cvt.curves.init import box_inside
from cvt.curves.reconstruction import curves_svg
from cvt.curves.strokes import load_curves
from cvt.curves.synthesis import CurveConfig
from cvt.limits import DEFAULT as LIMITS
from neuraltex.imageio import save_pil, stack_rows

ROOT = Path(__file__).resolve().parents[1]
EXEMPLARS = ROOT / "cvt" / "exemplars" / "curves"
DEFAULT = ("chain", "lace", "scribbles", "vines", "voronoi", "waves")
BAND = 2.0  # deltas
SHORT = 6  # samples


def disk_svg(box, radius: float) -> str:
    x0, y0, x1, y1 = box
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    return (f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{x0} {y0} {x1 - x0} {y1 - y0}">'
            f'<circle cx="{cx}" cy="{cy}" r="{radius}" fill="black"/></svg>')


def border_stats(g: CurveGraph, dom: Domain, delta: float) -> dict[str, float]:
    """The band / interior numbers of the docstring for the curve samples of ``g``."""
    g = g.select(torch.nonzero(g.kind < 0).flatten())
    depth = dom.depth(g.pos)
    band, inner = (depth >= 0) & (depth < BAND * delta), depth >= BAND * delta
    # areas by the same depth test on a fine grid of the domain's box
    x0, y0 = dom.rim.min(0)
    x1, y1 = dom.rim.max(0)
    step = delta / 4
    gx, gy = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    grid_depth = dom.depth(torch.from_numpy(np.stack([gx.ravel(), gy.ravel()], 1)))
    a_band = ((grid_depth >= 0) & (grid_depth < BAND * delta)).sum() * step**2
    a_inner = (grid_depth >= BAND * delta).sum() * step**2
    deg = g.degree().numpy()
    _, lab = components(len(g), g.edges.numpy())
    size = np.bincount(lab)
    short = np.unique(lab[band & (size[lab] < SHORT)])
    return {"band_density": (band.sum() / a_band) / max(inner.sum() / a_inner, 1e-12),
            "band_ends": 100 * float((deg[band] == 1).sum()) / max(int(band.sum()), 1),
            "inner_ends": 100 * float((deg[inner] == 1).sum()) / max(int(inner.sum()), 1),
            "short_pieces": float(len(short)), "outside": float((depth < 0).sum()),
            "samples": float(len(g))}


def evaluate(name: str, cfg: CurveConfig, scale: float, svg_dir: Path | None = None,
             pictures: dict[str, str] | None = None) -> dict[str, dict[str, float]]:
    """Both ways' numbers; their SVGs into ``svg_dir`` and ``pictures`` (label -> SVG)."""
    cx = load_curves(EXEMPLARS / f"{name}.svg")
    x, y, w, h = cx.exemplar.viewbox
    size = (scale * w, scale * h)
    box = (x, y, x + size[0], y + size[1])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "disk.svg"
        path.write_text(disk_svg(box, 0.45 * min(size)))
        inside = domain_inside(str(path), LIMITS)
    row = {}
    for label, pull in (("drop", 0.0), ("pull", cfg.domain_pull)):
        t = time.perf_counter()
        g, delta = run_curves("ours", cx, size, replace(cfg, domain_pull=pull), inside)
        seconds = time.perf_counter() - t
        dom = Domain.of(box_inside(box, inside), box, delta / 4)
        row[label] = {**border_stats(g, dom, delta), "seconds": seconds}
        svg = curves_svg(cx.exemplar, cx.element_centers(), g, size)
        if svg_dir is not None:
            (svg_dir / f"{name}.{label}.svg").write_text(svg)
        if pictures is not None:
            pictures[f"{name}: {label}"] = svg
    return row


def contact_sheet(pictures: dict[str, str], per_row: int = 6, height: int = 200):
    """The outputs (label -> SVG) rendered, ``per_row`` to a row."""
    from curve_gallery import labelled, render  # scripts/curve_gallery.py

    items = list(pictures.items())
    rows = [labelled([render(svg, height) for _, svg in items[k : k + per_row]],
                     [label for label, _ in items[k : k + per_row]])
            for k in range(0, len(items), per_row)]
    return stack_rows(rows, gap=8)


KEYS = ("band_density", "band_ends", "inner_ends", "short_pieces", "outside", "samples",
        "seconds")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help=f"shipped exemplar names (default: {DEFAULT})")
    ap.add_argument("--scale", type=float, default=1.5, help="output side / exemplar side")
    ap.add_argument("--seed", type=int, default=0, help="random seed")
    ap.add_argument("--pull", type=float, default=CurveConfig.domain_pull,
                    help="eq. 15 pull weight to measure against dropping (CurveConfig.domain_pull)")
    ap.add_argument("--out", type=Path, help="also write the markdown table here")
    ap.add_argument("--svg-dir", type=Path, help="keep the output SVGs here")
    ap.add_argument("--png", type=Path,
                    help="also write a picture of every output here (drop | pull per exemplar)")
    args = ap.parse_args()
    names = args.names or list(DEFAULT)
    missing = [n for n in names if not (EXEMPLARS / f"{n}.svg").exists()]
    if missing:
        ap.error(f"no shipped curve exemplar named {', '.join(missing)}")
    torch.set_num_threads(1)
    if args.svg_dir:
        args.svg_dir.mkdir(parents=True, exist_ok=True)
    if args.pull <= 0:
        ap.error("--pull must be > 0 (0 is the drop it is measured against)")
    cfg = CurveConfig(seed=args.seed, domain_pull=args.pull)
    lines = ["| exemplar | domain constraint | " + " | ".join(KEYS) + " |",
             "|---" * (len(KEYS) + 2) + "|"]
    rows, pictures = {}, {}
    for name in names:
        rows[name] = evaluate(name, cfg, args.scale, args.svg_dir, pictures)
        for label, v in rows[name].items():
            lines.append(f"| {name} | {label} | " + " | ".join(
                f"{v[k]:.0f}" if k in ("short_pieces", "outside", "samples") else f"{v[k]:.2f}"
                for k in KEYS) + " |")
        print(lines[-2], lines[-1], sep="\n", flush=True)
    lines.append("")
    for k in ("band_density", "band_ends", "short_pieces"):
        med = {lab: np.median([r[lab][k] for r in rows.values()]) for lab in ("drop", "pull")}
        lines.append(f"- median {k}: drop {med['drop']:.2f}, pull {med['pull']:.2f}")
    off = {lab: np.median([abs(1 - r[lab]["band_density"]) for r in rows.values()])
           for lab in ("drop", "pull")}
    lines.append(f"- median |1 - band_density| (0: the border as full as the inside): "
                 f"drop {off['drop']:.2f}, pull {off['pull']:.2f}")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.png:
        save_pil(contact_sheet(pictures), args.png)
    if args.out:
        args.out.write_text(f"Curves in a disk domain (`python scripts/eval_curve_domain.py "
                            f"--scale {args.scale:g}`), seed {args.seed}: eq. 15's pull "
                            f"against dropping the samples that leave the domain.\n\n"
                            + text + "\n" + __doc__.split("\n\n")[2] + "\n")


if __name__ == "__main__":
    main()
