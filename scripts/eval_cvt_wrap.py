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
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cvt.limits import SvgLimits  # noqa: E402
from cvt.svg import load_svg  # noqa: E402

LINES = 256
BAND = 3  # lines each side of the wrap line
NEAR = 0.06  # share of the tile
SAME = 0.02  # units: copies of one element (see distinct)


def tile_elements(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres on the tile (wrapped), half sizes and the tile size of the distinct elements
    of a tileable output. Shape: -> (E, 2), (E, 2), (2,)."""
    ex = load_svg(path, "groups", SvgLimits(max_points=10**8, max_elements=10**6,
                                            max_nodes=10**8, max_bytes=10**9))
    x0, y0, w, h = ex.viewbox
    b = np.stack([e.bbox for e in ex.elements])  # (E, 4)
    c = ((b[:, :2] + b[:, 2:]) / 2 - [x0, y0]) % [w, h]
    first = distinct(c, b[:, 2:] - b[:, :2], (w, h))
    return c[first], (b[first, 2:] - b[first, :2]) / 2, np.array([w, h])


def distinct(centres: np.ndarray, sizes: np.ndarray, period) -> np.ndarray:
    """Indices of the first of each group of copies: an element and its wrapped copies have
    one centre (on the torus) and one size up to SAME units. The file writes a translation
    with 6 significant digits, so a copy moved by a period (1200 units) lands up to 0.005
    units off its element; rounding to 2 decimals split about one such pair in ten and
    counted it twice, at the wrap only. Shape: (E, 2), (E, 2) -> (D,)."""
    period = np.asarray(period, float)
    tree = cKDTree(np.minimum(centres, np.nextafter(period, 0)), boxsize=period)
    pairs = tree.query_pairs(SAME, output_type="ndarray")  # (Q, 2)
    pairs = pairs[np.abs(sizes[pairs[:, 0]] - sizes[pairs[:, 1]]).max(1) < SAME]
    n = len(centres)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    _, first = np.unique(label, return_index=True)
    return np.sort(first)


def crossings(path: Path) -> tuple[np.ndarray, float, float]:
    """Per axis the distinct elements crossing each of LINES lines (line 0: the wrap); centres
    near a wrap line and the count expected there. Shape: -> (2, LINES), float, float."""
    c, half, size = tile_elements(path)
    out = []
    for a in (0, 1):
        pos = np.arange(LINES) * size[a] / LINES  # (L,)
        d = np.abs((c[:, a][:, None] - pos[None] + size[a] / 2) % size[a] - size[a] / 2)
        out.append((d < half[:, a][:, None]).sum(0))  # (L,)
    dist = np.minimum(c, size - c).min(1) / size.min()
    return np.array(out), float((dist < NEAR).sum()), len(c) * (1 - (1 - 2 * NEAR) ** 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", help="--seam-cache folder of eval_cvt.py --real --tileable")
    ap.add_argument("--pattern", default="*--tileable-*.svg", help="tile file names")
    ap.add_argument("--rolls", type=int, default=2000,
                    help="draws of the seamless reference: the same tiles with the wrap line "
                    "moved to a random line (default 2000)")
    args = ap.parse_args()
    if args.rolls < 1:
        ap.error("--rolls must be at least 1")
    per = defaultdict(lambda: ([], [0.0, 0.0]))
    for path in sorted(Path(args.folder).glob(args.pattern)):
        cross, near, expected = crossings(path)
        entry = per[path.name.split("-")[0]]
        entry[0].append(cross)
        entry[1][0] += near
        entry[1][1] += expected
    if not per:
        print(f"no tile matches {args.pattern} in {args.folder}", file=sys.stderr)
        sys.exit(2)
    rng = np.random.default_rng(0)
    every, every_null = [], []
    for name, (tiles, (near, expected)) in per.items():
        cross = np.stack(tiles).astype(float)  # (T, 2, L)
        ratio = wrap_ratio(cross, np.zeros(cross.shape[:2], int))  # (T, 2)
        null = wrap_ratio(cross, rng.integers(0, LINES, (args.rolls, *cross.shape[:2])))
        every.append(ratio)
        every_null.append(null)
        print(f"- {name}: elements crossing the wrap band / a mean line {ratio.mean():.2f} "
              f"+- {ratio.std() / np.sqrt(ratio.size):.2f} ({len(tiles)} tiles; rolled, "
              f"seamless: 5-95 % {_spread(null)}); centres near the wrap / expected "
              f"{near / expected:.2f}")
    ratio = np.concatenate([r.ravel() for r in every])
    null = np.concatenate([n.reshape(args.rolls, -1) for n in every_null], 1).mean(1)
    print(f"pooled: {ratio.mean():.3f} +- {ratio.std() / np.sqrt(ratio.size):.3f} over "
          f"{ratio.size} wrap lines; the same tiles rolled (no seam by construction): 5-95 % "
          f"{_spread(null)}, p = {np.mean(null >= ratio.mean()):.3f}")


def wrap_ratio(cross: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The crossings of the band of lines around line ``at`` over the tile's mean line, per
    tile and axis. Shape: cross (T, 2, L), at (..., T, 2) -> (..., T, 2)."""
    band = np.r_[0 : BAND + 1, LINES - BAND : LINES]  # (B,)
    lines = (np.asarray(at)[..., None] + band) % LINES  # (..., T, 2, B)
    t, a = np.indices(cross.shape[:2])  # (T, 2) each
    return cross[t[..., None], a[..., None], lines].mean(-1) / cross.mean(2)


def _spread(draws: np.ndarray) -> str:
    """5-95 % of the draws' pooled means."""
    m = draws.reshape(len(draws), -1).mean(1)
    return f"{np.quantile(m, 0.05):.2f}-{np.quantile(m, 0.95):.2f}"


if __name__ == "__main__":
    main()
