"""Picture of vector synthesis: each exemplar next to its 2x synthesis, rendered with resvg.

    python scripts/cvt_gallery.py --out docs/cvt_synthesis.png overlapping_leaves garden stars
    python scripts/cvt_gallery.py --real --out docs/cvt_real.png hero_ticTacToe \
        inkscape_polkadots_med emoji_butterflies_on_hearts emoji_flowers_with_leaves
"""

from __future__ import annotations

import argparse
import io
import tempfile
from pathlib import Path

from PIL import Image, ImageDraw
from tqdm import tqdm

from neuraltex.imageio import save_pil, stack_rows

ROOT = Path(__file__).resolve().parents[1]
EXEMPLARS = ROOT / "cvt" / "exemplars"


def render(svg: str, height: int) -> Image.Image:
    from cvt.raster import png_bytes

    im = Image.open(io.BytesIO(png_bytes(svg))).convert("RGB")
    return im.resize((round(im.width * height / im.height), height), Image.LANCZOS)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("names", nargs="*", default=["overlapping_leaves", "garden", "stars_and_dots"])
    ap.add_argument("--out", default="docs/cvt_synthesis.png")
    ap.add_argument("--height", type=int, default=360, help="height of each 2x synthesis")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--real", action="store_true", help="names are in data/cvt_real")
    args = ap.parse_args()
    folder = ROOT / "data" / "cvt_real" if args.real else EXEMPLARS

    rows = []
    for name in tqdm(args.names, desc="synthesize"):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "out.svg"
            from cvt.cli import main as cvt_main

            code = cvt_main(["synthesize", str(folder / f"{name}.svg"), "-o", str(out),
                             "--scale", "2", "--seed", str(args.seed), "--quiet"])
            if code:
                raise SystemExit(code)
            big = render(out.read_text(), args.height)
        small = render((folder / f"{name}.svg").read_text(), args.height // 2)
        row = Image.new("RGB", (small.width + big.width + 30, args.height + 18), "white")
        row.paste(small, (0, 18))
        row.paste(big, (small.width + 30, 18))
        ImageDraw.Draw(row).text((0, 2), f"{name}: exemplar | 2x synthesis", fill="black")
        rows.append(row)
    save_pil(stack_rows(rows, gap=10), args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
