"""The picture of patch-wise encoding for the docs (docs/tiled_encode.png): a photograph's
textons encoded whole and patch-wise (``neuraltex overlay --tile off|auto``), then the 2x
vector synthesis ``cvt synthesize --from-image`` makes from each.

    python scripts/tiled_pictures.py -o docs/tiled_encode.png
"""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def synthesized(image: Path, tile: str, scale: float, levels: int, iterations: int,
                folder: Path):
    """The ``cvt synthesize --from-image`` output of ``image`` rendered (PIL image), and the
    number of elements it placed."""
    from PIL import Image

    from cvt.cli import main as cvt_main
    from cvt.limits import SvgLimits
    from cvt.raster import png_bytes
    from cvt.svg import parse_svg

    out = folder / f"{tile}.svg"
    code = cvt_main(["synthesize", "--from-image", str(image), "--tile", tile, "--scale",
                     str(scale), "--levels", str(levels), "--iterations", str(iterations),
                     "-o", str(out), "--quiet"])
    if code != 0:
        raise SystemExit(f"cvt synthesize failed on {image} (--tile {tile})")
    text = out.read_text()
    placed = [e for e in parse_svg(text.encode(), limits=SvgLimits(max_elements=10**5)).elements
              if e.node.get("data-background") != "1"]
    return Image.open(io.BytesIO(png_bytes(text))).convert("RGB"), len(placed)


def main(argv: list[str] | None = None) -> int:
    import torch
    from PIL import Image, ImageDraw

    from neuraltex.imageio import load_image, save_pil, stack_rows
    from neuraltex.model import DEFAULT_MODEL, load_model
    from neuraltex.overlay import draw_overlay
    from neuraltex.tiled_encode import encode_image

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--image", type=Path, default=ROOT / "data" / "real_textures" / "brick.png",
                   help="the photograph (default data/real_textures/brick.png)")
    p.add_argument("-o", "--output", type=Path, required=True, help="the picture (.png)")
    p.add_argument("--scale", type=float, default=2.0, help="synthesis scale (default 2)")
    p.add_argument("--levels", type=int, default=3, help="cvt levels (default 3)")
    p.add_argument("--iterations", type=int, default=7, help="cvt iterations (default 7)")
    args = p.parse_args(argv)
    model = load_model(DEFAULT_MODEL)
    x = load_image(args.image)
    side = x.shape[-2]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for tile, label in (("off", "whole"), ("auto", "patch-wise (--tile auto)")):
            with torch.no_grad():
                enc = encode_image(model, x[None], tile)
            overlay = draw_overlay(x, enc.textons, enc.masks[0], scale=1)
            synth, placed = synthesized(args.image, tile, args.scale, args.levels,
                                        args.iterations, Path(tmp))
            synth = synth.resize((round(synth.width * side / synth.height), side))
            row = Image.new("RGB", (side + overlay.width + synth.width, side + 16), "white")
            row.paste(Image.fromarray((x.permute(1, 2, 0).numpy() * 255).astype("uint8")),
                      (0, 16))
            row.paste(overlay.resize((overlay.width * side // overlay.height, side)), (side, 16))
            row.paste(synth, (side + overlay.width, 16))
            n = int(enc.textons.num_effective()[0])
            ImageDraw.Draw(row).text(
                (2, 2), f"{label}: {n} textons; cvt --from-image x{args.scale:g}: {placed} "
                "elements", fill="black")
            rows.append(row)
            print(f"{label}: {n} textons, {placed} synthesized elements", flush=True)
    save_pil(stack_rows(rows, gap=4), args.output)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
