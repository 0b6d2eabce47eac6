"""Speed and size of patch-wise encoding (neuraltex/tiled_encode.py) against the whole-picture
encoding, on the real textures of data/real_textures at their size and enlarged.

For each picture size: seconds per encoding (median of ``--repeats`` after one warm-up; the
whole-picture run, ``--tile on`` and ``--tile auto`` as the commands run it), the effective
textons, the megabytes of the masks the encoding keeps (``Encoded.masks``) and the peak
resident memory of the process so far, and how many pictures ``auto`` tiles.

    python scripts/bench_tiled_encode.py                 # 25 textures at 256 and 512 px
    python scripts/bench_tiled_encode.py --sizes 1024 --limit 5
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def timed(fn, repeats: int):
    """(median seconds of ``repeats`` calls after one warm-up, the last result)."""
    out = fn()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def main(argv: list[str] | None = None) -> int:
    import torch
    import torch.nn.functional as F

    from neuraltex.imageio import load_image
    from neuraltex.model import DEFAULT_MODEL, load_model
    from neuraltex.tiled_encode import encode_image

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--textures", type=Path, default=ROOT / "data" / "real_textures",
                   help="folder of real textures (default data/real_textures)")
    p.add_argument("--sizes", type=int, nargs="+", default=[256, 512],
                   help="picture sides in px the textures are resized to (default 256 512)")
    p.add_argument("--limit", type=int, default=0, help="only the first N textures (0: all)")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per encoding")
    p.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    args = p.parse_args(argv)
    torch.set_num_threads(args.threads)
    model = load_model(DEFAULT_MODEL)
    paths = sorted(args.textures.glob("*.png"))[: args.limit or None]
    print(f"{len(paths)} textures of {args.textures.name}, {args.threads} thread(s), median of "
          f"{args.repeats}\n")
    print("| side | encoding | s / picture | effective textons | masks MB | pictures tiled | "
          "peak RSS MB |\n|---:|---|---:|---:|---:|---:|---:|")
    for side in args.sizes:
        rows = {"whole": [], "tile on": [], "tile auto": []}
        for path in paths:
            x = load_image(path)[None]
            x = F.interpolate(x, size=(side, side), mode="bilinear", align_corners=False,
                              antialias=side < x.shape[-1])
            with torch.no_grad():
                grid = model.encode(x).masks.shape[-2:]  # a tiled encoding's is twice as fine
                for name, tile in (("whole", "off"), ("tile on", "on"), ("tile auto", "auto")):
                    s, enc = timed(lambda x=x, tile=tile: encode_image(model, x, tile),
                                   args.repeats)
                    rows[name].append((s, int(enc.textons.num_effective()[0]),
                                       enc.masks.numel() * enc.masks.element_size() / 2**20,
                                       enc.masks.shape[-2:] != grid))
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        for name, r in rows.items():
            print(f"| {side} | {name} | {statistics.mean(v[0] for v in r):.3f} | "
                  f"{statistics.mean(v[1] for v in r):.0f} | "
                  f"{statistics.mean(v[2] for v in r):.1f} | {sum(v[3] for v in r)} / {len(r)} "
                  f"| {rss:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
