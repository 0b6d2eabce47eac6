"""What a new E_s does to the shipped autoencoder's reconstruction, before E_FC and G adapt.

The default model's E_s is replaced by the one of another export (e.g. the long segmenter
run), E_FC and G stay, and both models reconstruct (encode, decode; no ``fit``) the first
``--procedural`` images of the procedural benchmark and the real textures (at 128 px, the
model's training size). Prints the mean PSNR of each, and on how many images the new one
wins. With ``--model`` instead, the new one is that whole export (E_FC and G adapted around
the new E_s: the step after the swap).

    python scripts/eval_segmenter_swap.py --segmenter runs/long_segmenter/model.safetensors
    python scripts/eval_segmenter_swap.py --model runs/long_finetune/model.safetensors
    python scripts/eval_segmenter_swap.py --model runs/long/model.safetensors --pictures recon.png

``--pictures`` also writes the real textures' triplets (input | shipped | new), five a row.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from neuraltex.errors import InputError, cli_entry  # noqa: E402


def with_segmenter(weights: str, segmenter: str):
    """The model of ``weights`` with E_s (every ``segmenter.*`` tensor) from ``segmenter``."""
    from neuraltex.model import load_model

    model, donor = load_model(weights), load_model(segmenter).state_dict()
    state = model.state_dict()
    if any(donor[k].shape != v.shape for k, v in state.items() if k.startswith("segmenter.")):
        raise InputError(f"{segmenter}: its E_s does not fit the model of {weights}")
    model.load_state_dict({k: donor[k] if k.startswith("segmenter.") else v
                           for k, v in state.items()})
    return model


def reconstruct(model, x: torch.Tensor) -> torch.Tensor:
    """(3, H, W) -> the model's reconstruction (3, H, W)."""
    with torch.no_grad():
        return model.decode(model.encode(x[None]).textons, tuple(x.shape[-2:]))[0]


def pictures(procedural: int, textures: Path) -> dict[str, list[torch.Tensor]]:
    from neuraltex.data.splits import benchmark_split
    from neuraltex.imageio import load_image
    from neuraltex.nn_utils import resize

    proc = [torch.from_numpy(np.ascontiguousarray(it.load().image, dtype=np.float32))
            .permute(2, 0, 1) for it in benchmark_split()[:procedural]]
    real = [resize(load_image(p)[:3][None].float(), (128, 128))[0].clamp(0, 1)
            for p in sorted(textures.glob("*.png"))]
    return {"procedural": proc, "real (128 px)": real}


def contact_sheet(xs, recons, path: Path, per_row: int = 5) -> None:
    """input | shipped | new for each picture (3, H, W), ``per_row`` triplets a row."""
    from torchvision.utils import make_grid

    from neuraltex.imageio import save_image

    tiles = [t for x, (ra, rb) in zip(xs, recons, strict=True) for t in (x, ra, rb)]
    save_image(make_grid(tiles, nrow=3 * per_row, padding=2, pad_value=1.0), path)


@cli_entry("eval_segmenter_swap")
def main(argv: list[str] | None = None) -> int:
    from neuraltex.fit import psnr
    from neuraltex.model import DEFAULT_MODEL

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    new = p.add_mutually_exclusive_group(required=True)
    new.add_argument("--segmenter", help="export whose E_s replaces the default's")
    new.add_argument("--model", help="a whole export to compare with the default instead")
    p.add_argument("--weights", default=str(DEFAULT_MODEL),
                   help="the model whose E_FC and G stay (default: the shipped one)")
    p.add_argument("--procedural", type=int, default=60,
                   help="how many procedural benchmark images")
    p.add_argument("--textures", type=Path, default=ROOT / "data" / "real_textures",
                   help="folder of real textures (PNG)")
    p.add_argument("--pictures", type=Path,
                   help="PNG of the real textures: input | shipped | new, five triplets a row")
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    from neuraltex.model import load_model

    for path in (args.segmenter or args.model, args.weights):
        if not Path(path).is_file():
            raise InputError(f"no model at {path}")
    old = load_model(args.weights)
    new = load_model(args.model) if args.model else with_segmenter(args.weights, args.segmenter)
    label = "the new model" if args.model else "the new E_s"
    if args.pictures:
        from neuraltex.imageio import check_output_path

        check_output_path(args.pictures)
    for name, xs in pictures(args.procedural, args.textures).items():
        recons = [(reconstruct(old, x).clamp(0, 1), reconstruct(new, x).clamp(0, 1))
                  for x in tqdm(xs, desc=name, leave=False)]
        a, b = zip(*[(psnr(ra, x), psnr(rb, x)) for x, (ra, rb) in zip(xs, recons, strict=True)],
                   strict=True)
        if args.pictures and name.startswith("real"):
            contact_sheet(xs, recons, args.pictures)
        wins = sum(nb > na for na, nb in zip(a, b, strict=True))
        print(f"{name}: {len(xs)} images, PSNR shipped {np.mean(a):.2f} dB, with {label} "
              f"{np.mean(b):.2f} dB (better on {wins})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
