"""Pictures of curve synthesis (docs/): every shipped curve exemplar | the issue's
no-connectivity baseline (nearest-neighbour reconnection, no end repair) | the same with ours'
finish | ours, at 1.5x, same seed and settings as scripts/eval_curves.py (one baseline run for
both baseline pictures); and autocomplete examples (drawing | drawing + prediction).

    python scripts/curve_gallery.py [--out docs/curves_gallery.png]
        [--autocomplete docs/curves_autocomplete.png] [NAME ...]
    python scripts/curve_gallery.py --real --out docs/curves_gallery_real.png   # data/real_curves
"""

from __future__ import annotations

import argparse
from pathlib import Path

from PIL import Image, ImageDraw

from cvt.curves.autocomplete import autocomplete, region_around
from cvt.curves.baselines import run_staged
from cvt.curves.reconstruction import curves_svg
from cvt.curves.strokes import curve_exemplar, load_curves
from cvt.curves.synthesis import CurveConfig
from cvt.svg import parse_svg
from neuraltex.imageio import save_pil, stack_rows

EXEMPLARS = Path(__file__).resolve().parents[1] / "cvt" / "exemplars" / "curves"
REAL = Path(__file__).resolve().parents[1] / "data" / "real_curves"
NS = 'xmlns="http://www.w3.org/2000/svg"'
DRAWINGS = {  # a user's first strokes, in the exemplar's own style
    "waves": '<path d="M0 60 C 40 50, 70 70, 110 58" fill="none" stroke="#1d3557" '
             'stroke-width="2"/>',
    "lace": '<circle cx="100" cy="100" r="11" fill="none" stroke="#3a3a6a" stroke-width="1.6"/>'
            '<path d="M111 100 L129 100" fill="none" stroke="#3a3a6a" stroke-width="1.6"/>',
    "vines": '<path d="M0 100 C 40 90, 70 110, 120 100" fill="none" stroke="#2d6a4f" '
             'stroke-width="2.5"/>',
}


def render(svg: str, height: int) -> Image.Image:
    from cvt.raster import render_svg

    im = Image.fromarray((render_svg(svg) * 255).astype("uint8"))
    return im.resize((round(im.width * height / im.height), height), Image.LANCZOS)


def labelled(pics: list[Image.Image], labels: list[str], gap: int = 12) -> Image.Image:
    h = max(p.height for p in pics)
    row = Image.new("RGB", (sum(p.width + gap for p in pics), h + 16), "white")
    x = 0
    for p, text in zip(pics, labels, strict=True):
        row.paste(p, (x, 16))
        ImageDraw.Draw(row).text((x, 2), text, fill="black")
        x += p.width + gap
    return row


def gallery_row(path: Path, cfg: CurveConfig, scale: float, height: int) -> Image.Image:
    name = path.stem
    cx = load_curves(path)
    size = (scale * cx.exemplar.viewbox[2], scale * cx.exemplar.viewbox[3])
    pics = [render(path.read_text(), round(height / scale))]
    base = run_staged("no-connectivity", cx, size, cfg)
    for g in (base.plain, base.final, run_staged("ours", cx, size, cfg).final):
        pics.append(render(curves_svg(cx.exemplar, cx.element_centers(), g, size), height))
    return labelled(pics, [name, "no connectivity, nearest", "same + our finish", "ours"])


def autocomplete_row(name: str, cfg: CurveConfig, height: int) -> Image.Image:
    cx = load_curves(EXEMPLARS / f"{name}.svg")
    svg = f'<svg {NS} viewBox="0 0 200 200">{DRAWINGS[name]}</svg>'
    drawn = curve_exemplar(parse_svg(svg.encode()))
    res = autocomplete(cx, drawn, region_around(drawn, 50), cfg)
    out = curves_svg(cx.exemplar, cx.element_centers(), res.graph, (200, 200))
    return labelled([render(svg, height), render(out, height)],
                    [f"{name}: drawn", f"+ autocomplete ({res.seconds:.2f} s)"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("names", nargs="*", help="exemplars (default: all shipped)")
    ap.add_argument("--out", default="docs/curves_gallery.png")
    ap.add_argument("--autocomplete", default="docs/curves_autocomplete.png")
    ap.add_argument("--scale", type=float, default=1.5)
    ap.add_argument("--height", type=int, default=240, help="height of each synthesis")
    ap.add_argument("--real", action="store_true",
                    help="the real stroke art of data/real_curves (no autocomplete sheet)")
    args = ap.parse_args()
    folder = REAL if args.real else EXEMPLARS
    names = args.names or sorted(p.stem for p in folder.glob("*.svg"))
    rows = [gallery_row(folder / f"{n}.svg", CurveConfig(), args.scale, args.height)
            for n in names]
    half = (len(rows) + 1) // 2
    left, right = stack_rows(rows[:half], gap=8), stack_rows(rows[half:], gap=8)
    sheet = Image.new("RGB", (left.width + right.width + 20, left.height), "white")
    sheet.paste(left, (0, 0))
    sheet.paste(right, (left.width + 20, 0))
    save_pil(sheet, args.out)
    print(f"wrote {args.out}")
    if args.real:
        return
    ac = [autocomplete_row(n, CurveConfig(levels=2), args.height) for n in DRAWINGS]
    save_pil(stack_rows(ac, gap=8), args.autocomplete)
    print(f"wrote {args.autocomplete}")


if __name__ == "__main__":
    main()
