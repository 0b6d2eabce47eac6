"""Data throughput: procedural samples per second through a torch DataLoader.

    python scripts/bench_data.py                      # 128 px, 2 workers, augmented
    python scripts/bench_data.py --workers 0 --no-augment --n 200

Prints images/s after a warm-up batch (worker start-up is not counted), and the CPU
time per image over all processes: on a shared machine the wall-clock rate depends on
what else runs, the CPU cost does not. The target is >= 100 images/s at
128 px on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import torch  # noqa: E402
from torch.utils.data import DataLoader  # noqa: E402
from tqdm import tqdm  # noqa: E402

from neuraltex.data.augment import Augment  # noqa: E402
from neuraltex.data.datasets import InfiniteProceduralTextures  # noqa: E402
from neuraltex.errors import InputError, cli_entry  # noqa: E402


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="bench_data", description=__doc__.split("\n")[0])
    p.add_argument("--size", type=int, default=128, help="image side in px (default 128)")
    p.add_argument("--n", type=int, default=2000, help="images to time (default 2000)")
    p.add_argument("--batch", type=int, default=32, help="batch size (default 32)")
    p.add_argument("--workers", type=int, default=2, help="DataLoader workers (default 2)")
    p.add_argument("--no-augment", action="store_true", help="time generation only")
    return p


@cli_entry("bench_data")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.n < 1 or args.batch < 1 or args.workers < 0:
        raise InputError("--n and --batch must be >= 1, --workers >= 0")
    torch.set_num_threads(1)
    ds = InfiniteProceduralTextures(args.size, augment=None if args.no_augment else Augment())
    loader = DataLoader(ds, batch_size=args.batch, num_workers=args.workers,
                        persistent_workers=args.workers > 0,
                        prefetch_factor=4 if args.workers else None)
    cpu0 = _cpu_seconds()
    it = iter(loader)
    next(it)  # warm-up: worker start-up and imports
    done, t0 = 0, time.perf_counter()
    with tqdm(total=args.n, desc="images", unit="img") as bar:
        while done < args.n:
            batch = next(it)
            done += len(batch["image"])
            bar.update(len(batch["image"]))
    wall = time.perf_counter() - t0
    del it, loader  # joins the workers, so their CPU time shows up in RUSAGE_CHILDREN
    cpu = _cpu_seconds() - cpu0
    total = done + args.batch  # the warm-up batch was generated too
    print(f"{done} images of {args.size}px, {args.workers} workers, augment="
          f"{not args.no_augment}: {done / wall:.1f} images/s ({wall:.1f} s wall)")
    print(f"CPU time {1000 * cpu / total:.1f} ms/image (all processes) = "
          f"{total / cpu:.1f} images/s per fully available core "
          f"(load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    return 0


def _cpu_seconds() -> float:
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


if __name__ == "__main__":
    raise SystemExit(main())
