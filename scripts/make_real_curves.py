"""Regenerate the real stroke-art curve exemplars (data/real_curves/*.svg; sources in its
SOURCES.md).

Every stroke is third-party line art from a published Debian package; this script only crops
and normalizes it. Fetch the packages first (development time only, nothing is downloaded at
run time):

    mkdir -p /tmp/curve_src && cd /tmp/curve_src
    apt-get download openclipart-svg inkscape hershey-fonts-data
    for f in *.deb; do dpkg -x $f root; done
    python scripts/make_real_curves.py --src /tmp/curve_src/root/usr/share

* clip art (openclipart-svg, public domain / CC0): the document is parsed with cvt's SVG
  reader (transforms applied), its unfilled strokes are clipped to a crop window and scaled to
  a 200 x 200 canvas; filled shapes are left out (only stroke art is kept);
* stroke fonts (Hershey fonts, hershey-fonts-data): a paragraph of text set in the font, each
  pen-down run one polyline (handwriting-like connected strokes);
* hatches (Inkscape 1.2 ``share/inkscape/paint/hatches.svg``, GPL-2+): the hatch path
  repeated at its pitch across the canvas, at the hatch's rotation.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "real_curves"
S = 200.0  # canvas side

# name: (file under openclipart/svg, crop window x0, y0, side in the file's user units,
# description)
CLIPART = {
    "shoe_sole": ("people/clothing/shoe_print_01.svg", (15, 40, 90),
                  "hatched tread of a shoe print (crop of the forefoot)"),
    "coastline": ("geography/map_of_norway_jarno_vasa_01.svg", (190, 400, 130),
                  "fjord coastline of a map of Norway (crop of the west coast)"),
    "islands": ("geography/map_of_norway_jarno_vasa_01.svg", (380, 150, 130),
                "coast and islands of a map of Norway (crop of the north)"),
    "leaf_sketch": ("unsorted/foglie_verdi.svg", (20, 10, 200),
                    "sketchy outlines and veins of two leaves (crop)"),
}
# name: (font file under hershey-fonts, text, description)
FONTS = {
    "hershey_script": ("scriptc.jhf", "the quick brown fox jumps over the lazy dog and then "
                       "writes a long letter home about it all", "cursive script handwriting"),
    "hershey_gothic": ("gothiceng.jhf", "Hershey gothic letters drawn with a pen in many "
                       "strokes and loops", "blackletter text"),
}
# name: (hatch id in inkscape/paint/hatches.svg, description)
HATCHES = {"inkscape_hatch_zigzag": ("hatch9", "zigzag hatch rotated 45 degrees, at 2.5x")}
HATCH_ZOOM = 2.5  # the hatch's zigzag (10 units a period) spans a few sampling distances


def _fmt_path(p: np.ndarray, color: str, width: float) -> str:
    body = " L".join(f"{x:.2f},{y:.2f}" for x, y in p)
    return (f'<path d="M{body}" fill="none" stroke="{color}" stroke-width="{width:.3g}" '
            f'stroke-linecap="round" stroke-linejoin="round"/>')


def _doc(items: list[str], note: str) -> str:
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{S:g}" height="{S:g}" '
            f'viewBox="0 0 {S:g} {S:g}">\n<!-- {note} -->\n' + "\n".join(items) + "\n</svg>\n")


def clip_polyline(p: np.ndarray, box) -> list[np.ndarray]:
    """Pieces of a polyline inside ``box`` (x0, y0, x1, y1), cut where it leaves (points
    resampled finely first so the cut lands near the border). Shape: (P, 2) -> [(Q, 2)]."""
    x0, y0, x1, y1 = box
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    step = (x1 - x0) / 400
    fine = [p[:1]]
    for a, b, n in zip(p[:-1], p[1:], np.ceil(seg / step).astype(int), strict=True):
        t = np.linspace(0, 1, max(n, 1) + 1)[1:, None]
        fine.append(a + t * (b - a))
    q = np.vstack(fine)
    inside = (q[:, 0] >= x0) & (q[:, 0] <= x1) & (q[:, 1] >= y0) & (q[:, 1] <= y1)
    pieces, cur = [], []
    for pt, ok in zip(q, inside, strict=True):
        if ok:
            cur.append(pt)
        elif cur:
            pieces.append(np.array(cur))
            cur = []
    if cur:
        pieces.append(np.array(cur))
    return [x for x in pieces if len(x) >= 2]


def simplify(p: np.ndarray, tol: float) -> np.ndarray:
    """Ramer-Douglas-Peucker: the fewest points within ``tol`` of the polyline (keeps files
    small). Shape: (P, 2) -> (Q, 2)."""
    keep = np.zeros(len(p), dtype=bool)
    keep[[0, -1]] = True
    stack = [(0, len(p) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        d = p[j] - p[i]
        rel = p[i + 1 : j] - p[i]
        off = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) / max(np.linalg.norm(d), 1e-12)
        if np.linalg.norm(d) < 1e-12:
            off = np.linalg.norm(rel, axis=1)
        k = int(np.argmax(off))
        if off[k] > tol:
            keep[i + 1 + k] = True
            stack += [(i, i + 1 + k), (i + 1 + k, j)]
    return p[keep]


def crop_clipart(path: Path, window, note: str) -> str:
    """Unfilled strokes of an SVG inside the square ``window`` (x0, y0, side), scaled to S."""
    from cvt.svg import parse_svg

    ex = parse_svg(path.read_bytes())
    x0, y0, side = window
    k = S / side
    items = []
    for e in ex.elements:
        for s in e.shapes:
            if s.filled or s.stroke_width <= 0:
                continue
            for ring, closed in zip(s.rings, s.closed, strict=True):
                ring = np.vstack([ring, ring[:1]]) if closed else ring
                for piece in clip_polyline(ring, (x0, y0, x0 + side, y0 + side)):
                    q = simplify((piece - [x0, y0]) * k, 0.1)
                    items.append(_fmt_path(q, s.stroke_color or "#000000",
                                           max(s.stroke_width * k, 0.6)))
    return _doc(items, note)


def read_jhf(path: Path) -> dict[int, tuple[int, int, list[np.ndarray]]]:
    """Hershey glyphs by ASCII code (the file's order from 32): left, right, pen strokes."""
    lines = path.read_text(encoding="latin-1").splitlines()
    records, k = [], 0
    while k < len(lines):  # columns 1-5 glyph number, 6-8 vertex count, then 2 chars a vertex
        count, body = int(lines[k][5:8]), lines[k][8:]
        k += 1
        while len(body) < 2 * count and k < len(lines):  # long glyphs wrap over lines
            body, k = body + lines[k], k + 1
        records.append(body[: 2 * count])
    glyphs = {}
    for code, body in enumerate(records, start=32):
        pairs = [(ord(body[i]) - 82, ord(body[i + 1]) - 82) for i in range(0, len(body) - 1, 2)]
        left, right = pairs[0]
        strokes, cur = [], []
        for x, y in pairs[1:]:
            if (x, y) == (-50, 0):  # " R": pen up
                if len(cur) >= 2:
                    strokes.append(np.array(cur, float))
                cur = []
            else:
                cur.append((x, y))
        if len(cur) >= 2:
            strokes.append(np.array(cur, float))
        glyphs[code] = (left, right, strokes)
    return glyphs


def set_text(glyphs, text: str, size: float, line: float) -> list[np.ndarray]:
    """Strokes of ``text`` set in lines across the canvas, wrapped at words."""
    scale, out, x, y = size / 32, [], 6.0, 6 + size
    for word in text.split():
        width = sum(glyphs[ord(c)][1] - glyphs[ord(c)][0] for c in word + " ") * scale
        if x + width > S - 6 and x > 6:
            x, y = 6.0, y + line
        for c in word + " ":
            left, right, strokes = glyphs[ord(c)]
            out += [np.c_[x + (st[:, 0] - left) * scale, y + st[:, 1] * scale] for st in strokes]
            x += (right - left) * scale
    return out


def hershey(path: Path, text: str, note: str) -> str:
    strokes = set_text(read_jhf(path), (text + " ") * 3, 26.0, 36.0)
    items = [_fmt_path(simplify(p, 0.05), "#1b1b3a", 1.6) for s in strokes
             for p in clip_polyline(s, (0, 0, S, S))]
    return _doc(items, note)


def inkscape_hatch(path: Path, hatch: str, note: str) -> str:
    """The hatch's path (offset, pitch, rotation) repeated over the canvas."""
    text = path.read_text()
    m = re.search(rf'<hatch[^>]*id="{hatch}"[^>]*>(.*?)</hatch>', text, re.S)
    head = re.search(rf'<hatch[^>]*id="{hatch}"[^>]*>', text).group(0)
    pitch = float(re.search(r'pitch="([\d.]+)"', head).group(1))
    rot = np.radians(float((re.search(r'rotate="([-\d.]+)"', head) or [0, 0])[1]))
    d = re.search(r'd="([^"]*)"', m.group(1)).group(1)
    offset = float(re.search(r'offset="([\d.]+)"', m.group(1)).group(1))
    motif = np.array(re.findall(r"(-?[\d.]+),(-?[\d.]+)", d), float)  # one period along y
    period = motif[-1, 1] - motif[0, 1]
    reps = np.arange(-2 * S, 2 * S, period)
    unit = np.vstack([motif[:-1] + [0, r] for r in reps] + [motif[-1:] + [0, reps[-1]]])
    c, s = np.cos(rot), np.sin(rot)
    items = []
    for x in np.arange(-2 * S, 2 * S, pitch):
        p = (unit + [x + offset, 0]) * HATCH_ZOOM
        p = p @ np.array([[c, s], [-s, c]]) + S / 2
        items += [_fmt_path(simplify(q, 0.05), "#000000", 1.5)
                  for q in clip_polyline(p, (0, 0, S, S))]
    return _doc(items, note)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", type=Path, required=True,
                    help="usr/share of the unpacked packages (see the docstring)")
    ap.add_argument("--windows", nargs="*", default=[], metavar="NAME=X,Y,SIDE",
                    help="override a clip-art crop window")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    over = {k: tuple(map(float, v.split(","))) for k, v in (w.split("=") for w in args.windows)}
    for name, (rel, window, note) in CLIPART.items():
        svg = crop_clipart(args.src / "openclipart" / "svg" / rel, over.get(name, window), note)
        (OUT / f"{name}.svg").write_text(svg)
    for name, (font, text, note) in FONTS.items():
        (OUT / f"{name}.svg").write_text(hershey(args.src / "hershey-fonts" / font, text, note))
    for name, (hatch, note) in HATCHES.items():
        svg = inkscape_hatch(args.src / "inkscape" / "paint" / "hatches.svg", hatch, note)
        (OUT / f"{name}.svg").write_text(svg)
    print("wrote", len(CLIPART) + len(FONTS) + len(HATCHES), "files to", OUT)


if __name__ == "__main__":
    main()
