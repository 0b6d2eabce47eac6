"""Elements at the wrap lines of tileable outputs, counted from the SVGs (what a person would
see at the seam of the tiling: crowding, gaps), beside the pixel measure of cvt/seam.py.

    python scripts/eval_cvt.py --real --only emoji_ --extra=--tileable --seam-cache DIR
    python scripts/eval_cvt_wrap.py DIR                  # the tiles of all seeds in DIR

For every tile (one output, a torus) and axis: the number of distinct elements (wrapped
copies counted once) whose box crosses a line, for 256 lines across the tile; the wrap band
is the lines within 3 / 256 of the tile of the wrap line. Prints per exemplar and pooled the
band's count over the mean line's (1 on a seamless tiling, up to noise: the +- is the
standard error over tiles and axes) and the element centres within 6 % of the tile of a wrap
line over the expected share (1 - 0.88^2).
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cvt.limits import SvgLimits  # noqa: E402
from cvt.svg import load_svg  # noqa: E402

LINES = 256
BAND = 3  # lines each side of the wrap line
NEAR = 0.06  # share of the tile


def tile_elements(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres on the tile (wrapped), half sizes and the tile size of the distinct elements
    of a tileable output. Shape: -> (E, 2), (E, 2), (2,)."""
    ex = load_svg(path, "groups", SvgLimits(max_points=10**8, max_elements=10**6,
                                            max_nodes=10**8, max_bytes=10**9))
    x0, y0, w, h = ex.viewbox
    b = np.stack([e.bbox for e in ex.elements])  # (E, 4)
    c = ((b[:, :2] + b[:, 2:]) / 2 - [x0, y0]) % [w, h]
    _, first = np.unique(np.round(np.c_[c, b[:, 2:] - b[:, :2]], 2), axis=0, return_index=True)
    first = np.sort(first)  # an element and its wrapped copies: one centre, one size
    return c[first], (b[first, 2:] - b[first, :2]) / 2, np.array([w, h])


def wrap_counts(path: Path) -> tuple[list[float], float, float]:
    """Per axis the wrap band's crossings over the mean line's; centres near a wrap line and
    the count expected there."""
    c, half, size = tile_elements(path)
    out = []
    for a in (0, 1):
        pos = np.arange(LINES) * size[a] / LINES  # (L,)
        d = np.abs((c[:, a][:, None] - pos[None] + size[a] / 2) % size[a] - size[a] / 2)
        cross = (d < half[:, a][:, None]).sum(0)  # (L,)
        band = np.r_[0 : BAND + 1, LINES - BAND : LINES]
        out.append(cross[band].mean() / cross.mean())
    dist = np.minimum(c, size - c).min(1) / size.min()
    return out, float((dist < NEAR).sum()), len(c) * (1 - (1 - 2 * NEAR) ** 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", help="--seam-cache folder of eval_cvt.py --real --tileable")
    ap.add_argument("--pattern", default="*--tileable-*.svg", help="tile file names")
    args = ap.parse_args()
    per = defaultdict(lambda: ([], [0.0, 0.0]))
    for path in sorted(Path(args.folder).glob(args.pattern)):
        name = path.name.split("-")[0]
        bands, near, expected = wrap_counts(path)
        per[name][0].extend(bands)
        per[name][1][0] += near
        per[name][1][1] += expected
    every = []
    for name, (bands, (near, expected)) in per.items():
        every += bands
        print(f"- {name}: elements crossing the wrap band / a mean line {np.mean(bands):.2f} "
              f"+- {np.std(bands) / np.sqrt(len(bands)):.2f} ({len(bands) // 2} tiles); "
              f"centres near the wrap / expected {near / expected:.2f}")
    if every:
        print(f"pooled: {np.mean(every):.3f} +- {np.std(every) / np.sqrt(len(every)):.3f} over "
              f"{len(every)} wrap lines")


if __name__ == "__main__":
    main()
