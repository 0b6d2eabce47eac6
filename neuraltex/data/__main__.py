"""Export procedural textures with their texton masks, plus a contact sheet.

    python -m neuraltex.data --out data/demo --n 64
    python -m neuraltex.data --out data/hard --n 32 --families leaves,scales --size 256
    python -m neuraltex.data --out data/bench --split benchmark

Writes OUT/images/NNNNNN.png, OUT/masks/NNNNNN.png (16-bit ids, 0 = background),
OUT/meta.jsonl (family, easy/hard, parameters, texton count and centres) and
OUT/contact_sheet.png (images next to their mask overlays).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tqdm import tqdm

from neuraltex.data.export import contact_sheet, write_sample
from neuraltex.data.families import FAMILIES, FAMILY_NAMES
from neuraltex.data.generator import MAX_SIZE, MIN_SIZE
from neuraltex.data.splits import benchmark_split, check_training_seed, validation_split
from neuraltex.errors import InputError, cli_entry
from neuraltex.fileio import atomic_path, write_text_atomic


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m neuraltex.data",
                                description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--n", type=int, default=64, help="number of samples (default 64)")
    p.add_argument("--size", type=int, default=128, help="image side in px (default 128)")
    p.add_argument("--seed", type=int, default=0, help="training stream seed (default 0)")
    p.add_argument("--families", default=None,
                   help="comma list, round-robin (default: random per sample); "
                        f"choose from {', '.join(FAMILY_NAMES)}")
    p.add_argument("--split", choices=("benchmark", "validation"), default=None,
                   help="export a fixed split instead (ignores --n/--size/--seed/--families)")
    p.add_argument("--sheet", type=int, default=32,
                   help="samples on the contact sheet (default 32, 0 = none)")
    p.add_argument("--columns", type=int, default=4, help="contact sheet columns (default 4)")
    return p


def _items(args):
    if args.split:
        items = benchmark_split() if args.split == "benchmark" else validation_split()
        return [it.load for it in items]
    check_training_seed(args.seed)
    if args.n < 1:
        raise InputError(f"--n must be >= 1, got {args.n}")
    if not MIN_SIZE <= args.size <= MAX_SIZE:
        raise InputError(f"--size must be in [{MIN_SIZE}, {MAX_SIZE}], got {args.size}")
    families = None
    if args.families:
        families = [f.strip() for f in args.families.split(",") if f.strip()]
        for f in families:
            if f not in FAMILIES:
                raise InputError(f"unknown family {f!r}; choose from {', '.join(FAMILY_NAMES)}")
    from neuraltex.data.generator import generate

    def load(i: int):
        fam = families[i % len(families)] if families else None
        return lambda: generate(i, args.seed, args.size, family=fam)

    return [load(i) for i in range(args.n)]


@cli_entry("python -m neuraltex.data")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.sheet < 0 or args.columns < 1:
        raise InputError("--sheet must be >= 0 and --columns >= 1")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out exists and is not a folder: {out}")
    rows, sheet = [], []
    for i, load in enumerate(tqdm(_items(args), desc="export", unit="img")):
        sample = load()
        rows.append(write_sample(out, f"{i:06d}", sample))
        if len(sheet) < args.sheet:
            sheet.append(sample)
    write_text_atomic(out / "meta.jsonl", "".join(json.dumps(r) + "\n" for r in rows))
    if sheet:
        if len({s.mask.shape for s in sheet}) > 1:  # mixed sizes: keep the first size
            sheet = [s for s in sheet if s.mask.shape == sheet[0].mask.shape]
        with atomic_path(out / "contact_sheet.png") as tmp:
            contact_sheet(sheet, columns=args.columns).save(tmp)
    print(f"wrote {len(rows)} samples to {out}" + (" and contact_sheet.png" if sheet else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
