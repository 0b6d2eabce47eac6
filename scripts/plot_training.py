"""Learning curves of training runs as one PNG (no plotting library needed) and a text table.

    python scripts/plot_training.py runs/default_segmenter runs/default -o docs/curves.png
    python scripts/plot_training.py runs/a runs/b --tags loss/recon,diag/effective

Reads the TensorBoard scalars a run writes (run_dir/tb); each tag gets a panel, each run a
colour. Steps of a later run continue those of an earlier one when --chain is given (stage 2
started from stage 1's weights).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from PIL import Image, ImageDraw

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuraltex.errors import InputError, cli_entry  # noqa: E402
from neuraltex.imageio import save_pil  # noqa: E402

TAGS = ("loss/mask", "loss/recon", "diag/effective", "diag/queries_used", "diag/mask_diversity",
        "diag/l1")
COLOURS = ((31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (255, 127, 14))


def read_scalars(run: Path) -> dict[str, list[tuple[int, float]]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    if not (run / "tb").is_dir():
        raise InputError(f"{run}: no TensorBoard logs (expected {run / 'tb'})")
    ea = EventAccumulator(str(run / "tb"), size_guidance={"scalars": 0})
    ea.Reload()
    return {t: [(e.step, e.value) for e in ea.Scalars(t)] for t in ea.Tags()["scalars"]}


def smooth(points: list[tuple[int, float]], k: int) -> list[tuple[int, float]]:
    out = []
    for i in range(len(points)):
        window = points[max(0, i - k + 1):i + 1]
        out.append((points[i][0], sum(v for _, v in window) / len(window)))
    return out


def panel(draw: ImageDraw.ImageDraw, box, tag: str, series) -> None:
    x0, y0, x1, y1 = box
    draw.rectangle(box, outline=(180, 180, 180))
    draw.text((x0 + 4, y0 + 2), tag, fill=(0, 0, 0))
    pts = [p for s in series for p in s[1]]
    if not pts:
        return
    smin, smax = min(p[0] for p in pts), max(p[0] for p in pts)
    vmin, vmax = min(p[1] for p in pts), max(p[1] for p in pts)
    vmax = vmax if vmax > vmin else vmin + 1
    draw.text((x0 + 4, y1 - 12), f"{smin}..{smax} steps   [{vmin:.3g}, {vmax:.3g}]",
              fill=(90, 90, 90))

    def xy(s, v):
        return (x0 + 6 + (x1 - x0 - 12) * (s - smin) / max(1, smax - smin),
                y1 - 16 - (y1 - y0 - 34) * (v - vmin) / (vmax - vmin))

    for colour, points in series:
        if len(points) > 1:
            draw.line([xy(s, v) for s, v in points], fill=colour, width=2)


@cli_entry("plot_training")
def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="plot_training", description=__doc__.split("\n")[0])
    p.add_argument("runs", nargs="+", type=Path, help="run directories (with tb/)")
    p.add_argument("-o", "--output", type=Path, default=None, help="PNG to write")
    p.add_argument("--tags", default=",".join(TAGS), help="comma list of scalar tags")
    p.add_argument("--chain", action="store_true", help="runs are consecutive stages")
    p.add_argument("--smooth", type=int, default=5, help="moving-average window (points)")
    args = p.parse_args(argv)
    tags = [t for t in args.tags.split(",") if t]
    data, offset = [], 0
    for run in args.runs:
        scalars = read_scalars(run)
        shifted = {t: [(s + offset, v) for s, v in pts] for t, pts in scalars.items()}
        data.append((run, shifted))
        if args.chain:
            offset = max((s for pts in shifted.values() for s, _ in pts), default=offset)
    tags = [t for t in tags if any(t in d for _, d in data)]
    if not tags:
        raise InputError("none of the requested tags was logged by these runs")
    for tag in tags:
        print(f"{tag}:")
        for run, d in data:
            pts = d.get(tag, [])
            if pts:
                k = max(1, len(pts) // 10)
                row = " ".join(f"{s}:{v:.3g}" for s, v in smooth(pts, args.smooth)[::k])
                print(f"  {run.name}: {row}")
    if args.output:
        cols, w, h = 3, 360, 200
        rows = -(-len(tags) // cols)
        pic = Image.new("RGB", (cols * w, rows * h + 24), "white")
        draw = ImageDraw.Draw(pic)
        for i, (run, _) in enumerate(data):
            draw.text((6 + 180 * i, 6), run.name, fill=COLOURS[i % len(COLOURS)])
        for j, tag in enumerate(tags):
            r, c = divmod(j, cols)
            series = [(COLOURS[i % len(COLOURS)], smooth(d.get(tag, []), args.smooth))
                      for i, (_, d) in enumerate(data)]
            panel(draw, (c * w + 4, 24 + r * h + 4, (c + 1) * w - 4, 24 + (r + 1) * h - 4),
                  tag, series)
        save_pil(pic, args.output)
        print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
