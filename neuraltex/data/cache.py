"""Procedural training items written to disk once and read back memory-mapped.

Every procedural item is a pure function of (seed, index) and the generator's code, so a run
can read its items from a folder written beforehand instead of rendering them while it
trains: on 2 cores the data worker's 50-60 ms of CPU a batch otherwise competes with the
step's two threads (docs/training_speed.md). The first ``len(cache)`` indices come from the
folder; later ones are generated as before, so a cache shorter than the run is fine.

    python -m neuraltex.data.cache runs/data_cache --items 35200      # stages 1-2 as shipped
    python -m train experiment=default data.cache=runs/data_cache

The folder holds ``images.npy`` (N, H, W, 3) uint8, ``masks.npy`` (N, H, W) uint16 (0 =
background, 1..K textons), ``families.npy`` (N,) uint8 (index into FAMILY_NAMES) and
``meta.json``: what the items are (seed, size, families, augmentation, the generator code's
hash) and how many are written. Writing resumes where it stopped. A cache whose meta does
not match the dataset (other settings, or the generator's code changed since) is refused.
Images are stored as 8-bit (at most 1/510 from the float rendering, as any photograph).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset

from neuraltex.data.augment import Augment
from neuraltex.data.datasets import ProceduralTextures
from neuraltex.data.families import FAMILY_NAMES
from neuraltex.data.generator import MAX_SIZE, MIN_SIZE
from neuraltex.errors import InputError, cli_entry
from neuraltex.fileio import write_text_atomic

FORMAT = 1
MAX_ITEMS = 10_000_000
CHUNK = 256  # items written between two updates of meta.json


def code_hash() -> str:
    """sha256 of the data package's sources: the items are a function of this code."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        if path.name not in ("cache.py", "__main__.py", "export.py"):
            h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


def describe(ds: ProceduralTextures) -> dict:
    """What a procedural dataset's items are (the part of meta.json that must match)."""
    return {"format": FORMAT, "seed": ds.seed, "size": ds.size, "families": ds.families,
            "augment": dataclasses.asdict(ds.augment) if ds.augment is not None else None,
            "reference_size": ds.reference_size, "epoch": ds.epoch, "code": code_hash()}


def _read_meta(folder: Path) -> dict | None:
    try:
        meta = json.loads((folder / "meta.json").read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        raise InputError(f"data cache {folder}: unreadable meta.json ({exc})") from exc
    if not isinstance(meta, dict):
        raise InputError(f"data cache {folder}: meta.json is not an object")
    return meta


def _check(meta: dict, want: dict, folder: Path) -> None:
    diff = [k for k in want if meta.get(k) != json.loads(json.dumps(want[k]))]  # tuples: lists
    if diff:
        raise InputError(f"data cache {folder} holds other items ({', '.join(diff)} differ"
                         + (": the generator's code changed since it was written" if "code" in diff
                            else "") + "); write a new one")


def _check_space(folder: Path, need: int) -> None:
    existing = next(p for p in (folder, *folder.absolute().parents) if p.exists())
    free = shutil.disk_usage(existing).free
    if need > free:
        raise InputError(f"the data cache needs {_size(need)}; {existing} has {_size(free)} "
                         "free")


def _size(n: int) -> str:
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB"


class _Items(Dataset):
    """Items start .. stop - 1 of ``ds`` as (image uint8 (H, W, 3), mask uint16, family)."""

    def __init__(self, ds: ProceduralTextures, start: int, stop: int):
        self.ds, self.start, self.stop = ds, start, stop

    def __len__(self) -> int:
        return self.stop - self.start

    def __getitem__(self, i: int):
        it = self.ds.item(self.start + i)
        image = (it["image"].permute(1, 2, 0).numpy() * 255).round().astype(np.uint8)
        if int(it["mask"].max()) > np.iinfo(np.uint16).max:
            raise ValueError(f"item {self.start + i}: more than 65535 textons")
        return image, it["mask"].numpy().astype(np.uint16), FAMILY_NAMES.index(it["family"])


def write_cache(ds: ProceduralTextures, folder: str | Path, items: int, workers: int = 2,
                progress: bool = True) -> int:
    """Write items 0 .. ``items`` - 1 of ``ds`` to ``folder`` (resuming a partial cache of
    the same items); returns how many the folder holds."""
    from tqdm import tqdm

    if not 1 <= items <= MAX_ITEMS:
        raise InputError(f"--items must be in [1, {MAX_ITEMS}], got {items}")
    if not MIN_SIZE <= ds.size <= MAX_SIZE:
        raise InputError(f"--size must be in [{MIN_SIZE}, {MAX_SIZE}], got {ds.size}")
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"data cache {folder}: not a folder")
    if not (folder / "meta.json").exists():  # a new cache: its files must fit on the disk
        _check_space(folder, items * ds.size ** 2 * 5)  # bytes: 3 an image pixel, 2 a mask's
    want = describe(ds)
    meta = _read_meta(folder)
    if meta is not None:
        _check(meta, want, folder)
        if meta.get("items") != items:
            raise InputError(f"data cache {folder} was started with {meta.get('items')} items; "
                             "give the same --items or a new folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"data cache {folder}: cannot create it ({exc.strerror})") from exc
    s = ds.size
    shapes = {"images": ((items, s, s, 3), np.uint8), "masks": ((items, s, s), np.uint16),
              "families": ((items,), np.uint8)}
    mode = "r+" if meta is not None else "w+"
    try:
        arrays = {k: np.lib.format.open_memmap(folder / f"{k}.npy", mode=mode, dtype=dt,
                                               shape=sh) for k, (sh, dt) in shapes.items()}
    except (OSError, ValueError) as exc:
        raise InputError(f"data cache {folder}: unreadable ({exc})") from exc
    done = _filled(meta, arrays, s, folder) if meta is not None else 0
    bar = tqdm(total=items, initial=done, desc="data cache", unit="item", disable=not progress)
    try:
        while done < items:
            stop = min(done + CHUNK, items)
            loader = DataLoader(_Items(ds, done, stop), batch_size=None, num_workers=workers)
            for k, (image, mask, family) in enumerate(loader):
                arrays["images"][done + k] = image
                arrays["masks"][done + k] = mask
                arrays["families"][done + k] = family
                bar.update(1)
            for a in arrays.values():
                a.flush()
            # meta.json last: a chunk counts once it is on disk
            write_text_atomic(folder / "meta.json", json.dumps({**want, "items": items,
                                                                 "filled": stop}, indent=1))
            done = stop
    except OSError as exc:  # e.g. the disk filled up: what is written stays resumable
        raise InputError(f"data cache {folder}: writing failed after {done} items "
                         f"({exc.strerror or exc}); the same command resumes") from exc
    finally:
        bar.close()
    return done


def _filled(meta: dict, arrays: dict, size: int, folder: Path) -> int:
    """meta.json's count of written items, checked against the arrays' shapes and types."""
    n, filled = meta.get("items"), meta.get("filled")
    want = {"images": ((n, size, size, 3), np.uint8), "masks": ((n, size, size), np.uint16),
            "families": ((n,), np.uint8)}
    bad = [k for k, (shape, dt) in want.items()
           if arrays[k].shape != shape or arrays[k].dtype != dt]
    if not isinstance(filled, int) or not isinstance(n, int) or not 0 <= filled <= n or bad:
        raise InputError(f"data cache {folder}: damaged (meta.json's counts or "
                         f"{', '.join(bad) or 'its arrays'} do not match); write a new one")
    if filled and int(arrays["families"][:filled].max()) >= len(FAMILY_NAMES):
        raise InputError(f"data cache {folder}: damaged (unknown family ids)")
    return filled


class CachedTextures(Dataset):
    """``ds`` (a :class:`ProceduralTextures`) whose first items are read from a folder
    written by :func:`write_cache` (memory-mapped; the same dicts as ``ds.item``, the image
    from 8 bits); items beyond it are generated."""

    def __init__(self, ds: ProceduralTextures, folder: str | Path):
        folder = Path(folder)
        meta = _read_meta(folder)
        if meta is None:
            raise InputError(f"data cache {folder}: no meta.json (write one with "
                             "python -m neuraltex.data.cache)")
        _check(meta, describe(ds), folder)
        self.ds, self.folder, self._arrays = ds, folder, None
        self.filled = _filled(meta, self._open(), ds.size, folder)
        self._arrays = None  # mapped again lazily: each DataLoader worker maps its own

    def __len__(self) -> int:
        return len(self.ds)

    def _open(self) -> dict:
        if self._arrays is None:
            try:
                self._arrays = {k: np.load(self.folder / f"{k}.npy", mmap_mode="r",
                                           allow_pickle=False)
                                for k in ("images", "masks", "families")}
            except (OSError, ValueError) as exc:
                raise InputError(f"data cache {self.folder}: unreadable ({exc})") from exc
        return self._arrays

    def __getitem__(self, index: int) -> dict:
        if not 0 <= index < len(self.ds):
            raise IndexError(index)
        if index >= self.filled:
            return self.ds.item(index)
        a = self._open()
        image = torch.from_numpy(a["images"][index].transpose(2, 0, 1).astype(np.float32) / 255)
        mask = torch.from_numpy(a["masks"][index].astype(np.int64))
        return {"image": image, "mask": mask, "count": int(mask.max()),
                "family": FAMILY_NAMES[int(a["families"][index])], "index": index}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m neuraltex.data.cache",
                                description=__doc__.split("\n")[0])
    p.add_argument("folder", help="the cache folder (resumed if it holds a partial cache)")
    p.add_argument("--items", type=int, required=True,
                   help="items to write: steps x batch size of the runs that read it (stage 1 "
                   "as shipped: 4,400 x 8 = 35,200; stage 2 reads the first 25,600 of them)")
    p.add_argument("--size", type=int, default=128, help="image side in px (default 128, "
                   "the shipped model's data.size)")
    p.add_argument("--seed", type=int, default=0, help="training stream (default 0)")
    p.add_argument("--families", default=None,
                   help="comma list, round-robin (default: all, drawn per item)")
    p.add_argument("--no-augment", action="store_true",
                   help="items without augmentation (as data.augment=false)")
    p.add_argument("--workers", type=int, default=2, help="processes rendering (default 2)")
    return p


@cli_entry("python -m neuraltex.data.cache")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.workers < 0:
        raise InputError("--workers must be >= 0")
    families = [f.strip() for f in args.families.split(",") if f.strip()] if args.families \
        else None
    ds = ProceduralTextures(MAX_ITEMS, size=args.size, seed=args.seed, families=families,
                            augment=None if args.no_augment else Augment())
    n = write_cache(ds, args.folder, args.items, args.workers)
    print(f"wrote {n} items to {args.folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
