"""Side by side: ``neuraltex synthesize`` of texture files with and without their detail sprites
(the same arrangement, seed and decoder; only the sprites are dropped), one row per texture.

    neuraltex fit data/real_textures/leopard.png -o /tmp/leopard.ntex --steps 300
    python scripts/synthesis_sprites.py /tmp/leopard.ntex -o docs/synthesis_sprites.png

The numbers, beside the baselines, come from scripts/eval_synthesis.py; this script is for the
eyes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import torch  # noqa: E402
from make_gallery import strip  # noqa: E402

from neuraltex.cli.common import textons_of  # noqa: E402
from neuraltex.imageio import save_pil, stack_rows  # noqa: E402
from neuraltex.limits import Limits  # noqa: E402
from neuraltex.model import DEFAULT_MODEL, load_model  # noqa: E402
from neuraltex.texton_detail import split  # noqa: E402
from neuraltex.texton_synthesis import ArrangeSettings, synthesize_texture  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("textures", nargs="+", type=Path, help="texture files (.ntex)")
    ap.add_argument("-o", "--output", type=Path, required=True, help="picture to write (.png)")
    ap.add_argument("--size", type=int, default=384, help="square output side (384)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    torch.set_num_threads(1)
    model = load_model(DEFAULT_MODEL)
    rows = []
    for path in args.textures:
        tex = textons_of(model, path, Limits())
        plain = tex.decoder.generator.feature_channels - 2  # [f_a, d]; sprites after
        tiles = []
        for label, t in (("with sprites", tex.textons),
                         ("G alone", split(tex.textons, plain)[0])):
            img, _ = synthesize_texture(tex.decoder, t, tex.short, (args.size, args.size),
                                        ArrangeSettings(seed=args.seed))
            tiles.append((f"{path.stem}: {label}", img))
        rows.append(strip(tiles, height=args.size))
        print(f"{path.stem}: done", flush=True)
    save_pil(stack_rows(rows), args.output)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
