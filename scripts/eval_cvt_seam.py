"""The seam of tileable outputs, pooled over many tiles, beside seamless and real seams.

Per-line patch SWD and colour step, pooled over many tiles, beside their seamless reference
and two kinds of real seams.

    python scripts/eval_cvt.py --real --only emoji_ --extra=--tileable --seam-cache DIR
    python scripts/eval_cvt_seam.py DIR            # the tiles of all seeds in DIR

Every tile (one output, rendered at --width px) gives per axis the value of each line every
STEP px (cvt.seam): its patch SWD (patches straddling the line against those beside it) and
its colour step. A tile axis reads seam / interior: for patch SWD the seam line over the mean
of the controls MARGIN px or more away (as cvt.seam.seam_ratio), for the colour step the seam
line over the lines 1-8 px either side (cvt.seam.step_ratio: they cross the same motifs, so
what a line crosses cancels out); "colour step in phase" the same, but on an exactly periodic
tile (a lattice whose cell divides it) against the lines one, two ... periods away
(cvt.seam.step_offsets: a seam along a cell border is compared with the interior cell
borders, not with the lines inside the cells beside it). The ratio of a set of tiles is the
mean over its tile axes. Printed per exemplar and pooled over all exemplars, for
- the --tileable tiles (``*--tileable-*.svg``; the target: within 1.1);
- the same tiles rolled (the seam moved to a random line: seamless by construction), the
  estimator's noise: the share of draws within 1.1 and their 95th percentile;
- real seams: the plain outputs (``*-full-*.svg``, not tileable) and the tiles cut by
  --shift px at the seam (cvt.seam.misaligned: the two sides out of register).
"""

from __future__ import annotations

import argparse
import io
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cvt.seam import (  # noqa: E402
    MARGIN_RATIO,
    STEP,
    _projected,
    line_swd,
    misaligned,
    phase_step_ratio,
    pooled_ratios,
    rolled_draws,
    seam_and_inner,
    step_lines,
    step_profile,
    step_ratio,
)


def swd_ratio(values: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Patch SWD of the seam line over its controls. Shape: (n,), (D,) -> (D,)."""
    seam, inner = seam_and_inner(values, at, STEP)
    return seam / inner


MEASURES = {"patch SWD": swd_ratio, "colour step": step_ratio,
            "colour step in phase": phase_step_ratio}


def lines_of(image: np.ndarray, measures) -> dict:
    """Per measure, the per-line values of both axes. Shape: (H, W, 3) -> {name: ((n0,), (n1,))}."""
    out = {"colour step": step_profile(image)}
    if "colour step in phase" in measures:
        out["colour step in phase"] = step_lines(image)
    if "patch SWD" in measures:
        maps = _projected(image)
        out["patch SWD"] = tuple(line_swd(maps, axis, np.arange(0, image.shape[axis], STEP))
                                 for axis in (1, 0))
    return out


def render(path: Path, width: int) -> np.ndarray:
    from PIL import Image

    from cvt.raster import png_bytes

    png = png_bytes(path.read_text(), width=width)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.float32) / 255


def own_seams(tiles: list[dict], name: str) -> np.ndarray:
    """Ratio of the tiles' own seams (line 0) for ``name``."""
    return pooled_ratios(MEASURES[name], [t[name] for t in tiles], np.zeros((1, len(tiles), 2),
                                                                           int))


def rolled_seams(tiles: list[dict], name: str, rolls: int) -> np.ndarray:
    """(rolls,) ratios of the same tiles rolled to random lines for ``name``: seamless by
    construction, the measure's own noise."""
    values = [t[name] for t in tiles]
    return pooled_ratios(MEASURES[name], values, rolled_draws(values, rolls))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", help="--seam-cache folder of eval_cvt.py --real --tileable")
    ap.add_argument("--width", type=int, default=512,
                    help="render width of a tile in px (default 512: the judge's pixels at "
                    "--scale 2, 128 px per exemplar width)")
    ap.add_argument("--shift", type=int, default=4,
                    help="px cut off the tiles at the seam for the misaligned tiles (default 4)")
    ap.add_argument("--rolls", type=int, default=2000,
                    help="draws of the seamless reference (default 2000)")
    ap.add_argument("--measures", nargs="+", choices=tuple(MEASURES), default=tuple(MEASURES),
                    metavar="M", help="patch SWD (about 3 CPU s a tile), colour step and/or colour "
                    "step in phase (default all three; quote each)")
    args = ap.parse_args()
    if args.width < 4 * STEP or not 0 < args.shift < args.width // 4 or args.rolls < 1:
        ap.error("need --width >= 32, 0 < --shift < width / 4 and --rolls >= 1")
    sets = defaultdict(lambda: defaultdict(list))  # set -> exemplar -> tiles
    for path in sorted(Path(args.folder).glob("*.svg")):
        name, kind = path.name.split("-")[0], "tileable" if "--tileable-" in path.name else (
            "plain" if "-full-" in path.name else None)
        if kind is None:
            continue
        image = render(path, args.width)
        sets[kind][name].append(lines_of(image, args.measures))
        if kind == "tileable":
            sets["misaligned"][name].append(lines_of(misaligned(image, args.shift),
                                                     args.measures))
        print(f"{path.name}", file=sys.stderr, flush=True)
    if not sets["tileable"]:
        print(f"no tileable tile (*--tileable-*.svg) in {args.folder}", file=sys.stderr)
        sys.exit(2)
    for measure in args.measures:
        report(sets, measure, args)


def report(sets, measure: str, args) -> None:
    """Per exemplar and pooled: the tiles' ratio, its seamless reference, the real seams."""
    print(f"\n{measure}: seam / interior, mean over tile axes (target <= {MARGIN_RATIO})\n")
    every = {k: [] for k in ("tileable", "misaligned", "plain")}
    nulls = []
    for name, tiles in sets["tileable"].items():
        null = rolled_seams(tiles, measure, args.rolls)
        nulls.append(null)
        row = {k: own_seams(sets[k][name], measure) for k in every if sets[k][name]}
        for k in row:
            every[k] += sets[k][name]
        print(f"- {name}: tiles {row['tileable'][0]:.3f} ({len(tiles)} tiles; rolled, "
              f"seamless: 5-95 % {np.quantile(null, 0.05):.2f}-{np.quantile(null, 0.95):.2f}, "
              f"within {MARGIN_RATIO} in {np.mean(null <= MARGIN_RATIO):.0%}); misaligned by "
              f"{args.shift} px {row['misaligned'][0]:.2f}"
              + (f"; plain outputs {row['plain'][0]:.2f} ({len(sets['plain'][name])})"
                 if "plain" in row else ""))
    weights = np.array([len(t) for t in sets["tileable"].values()], float)
    null = np.average(np.stack(nulls), axis=0, weights=weights)  # (rolls,) all tile axes
    pooled = {k: own_seams(v, measure)[0] for k, v in every.items() if v}
    flagged = {k: np.mean([own_seams(sets[k][n], measure)[0] > MARGIN_RATIO for n in sets[k]])
               for k in ("misaligned", "plain") if sets[k]}
    print(f"pooled over {len(weights)} exemplars, {int(weights.sum())} tiles: tiles "
          f"{pooled['tileable']:.3f}; rolled (seamless): 5-95 % {np.quantile(null, 0.05):.3f}-"
          f"{np.quantile(null, 0.95):.3f}, within {MARGIN_RATIO} in "
          f"{np.mean(null <= MARGIN_RATIO):.1%} of draws, as high as the tiles in "
          f"{np.mean(null >= pooled['tileable']):.1%}; misaligned by {args.shift} px "
          f"{pooled['misaligned']:.2f} (over {MARGIN_RATIO} on {flagged['misaligned']:.0%} of "
          f"exemplars)" + (f"; plain outputs {pooled['plain']:.2f} (over {MARGIN_RATIO} on "
                           f"{flagged['plain']:.0%} of exemplars)" if "plain" in pooled else ""))


if __name__ == "__main__":
    main()
