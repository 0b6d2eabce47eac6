"""Rows of input | ground-truth textons | the model's textons | reconstruction on benchmark
images, per family, with each image's matched mIoU: the pictures of MODEL.md.

    python scripts/benchmark_overlays.py --families discs,two_tone,strokes,scales -o docs/x.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch
from PIL import Image, ImageDraw

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from neuraltex.data.export import overlay, to_uint8  # noqa: E402
from neuraltex.data.families import FAMILY_NAMES  # noqa: E402
from neuraltex.data.splits import benchmark_split  # noqa: E402
from neuraltex.errors import InputError, cli_entry  # noqa: E402
from neuraltex.imageio import save_pil, stack_rows  # noqa: E402
from neuraltex.metrics import texton_scores  # noqa: E402
from neuraltex.overlay import draw_overlay  # noqa: E402

LABEL_H = 14


@cli_entry("benchmark_overlays")
def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="benchmark_overlays", description=__doc__.split("\n")[0])
    p.add_argument("--checkpoint", default=None, help="model .safetensors (default: shipped)")
    p.add_argument("--families", default="discs,two_tone,strokes,scales",
                   help=f"comma list of {', '.join(FAMILY_NAMES)}")
    p.add_argument("--per-family", type=int, default=1, help="images per family")
    p.add_argument("-o", "--output", type=Path, required=True, help="PNG to write")
    args = p.parse_args(argv)
    from neuraltex.baselines import model_segmenter
    from neuraltex.model import DEFAULT_MODEL, load_model

    families = [f.strip() for f in args.families.split(",") if f.strip()]
    for f in families:
        if f not in FAMILY_NAMES:
            raise InputError(f"unknown family {f!r}")
    ckpt = args.checkpoint or DEFAULT_MODEL
    model, segment = load_model(ckpt), model_segmenter(ckpt)
    rows = []
    for fam in families:
        items = [it for it in benchmark_split() if it.family == fam and it.size == 128]
        for it in items[:args.per_family]:
            s = it.load()
            x = torch.from_numpy(s.image).permute(2, 0, 1).float()
            with torch.no_grad():
                enc = model.encode(x[None])
                recon = model.decode(enc.textons, tuple(x.shape[-2:]))[0]
            miou = texton_scores(segment(s.image), s.mask)["miou"]
            cells = [Image.fromarray(to_uint8(s.image)),
                     Image.fromarray(to_uint8(overlay(s.image, s.mask))),
                     draw_overlay(x, enc.textons, enc.masks[0]),
                     Image.fromarray((recon.clamp(0, 1).permute(1, 2, 0).numpy() * 255)
                                     .astype(np.uint8))]
            w, h = cells[0].size
            row = Image.new("RGB", (4 * w, h + LABEL_H), "white")
            for i, c in enumerate(cells):
                row.paste(c.resize((w, h)), (i * w, LABEL_H))
            ImageDraw.Draw(row).text((2, 1), f"{fam} #{it.index}: matched mIoU {miou:.2f}  "
                                     "| input | ground truth | model textons | reconstruction",
                                     fill=(0, 0, 0))
            rows.append(row)
    save_pil(stack_rows(rows), args.output)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
