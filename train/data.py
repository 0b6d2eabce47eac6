"""Training data: a dataset from the config and a loader whose batch at step s is fixed by s,
so a resumed run sees exactly the batches the uninterrupted run would have seen."""

from __future__ import annotations

from collections.abc import Iterator

import torch
from torch.utils.data import DataLoader, Dataset, Sampler


def build_dataset(cfg, total_items: int) -> Dataset:
    from neuraltex.data.augment import Augment

    augment = Augment() if cfg.augment else None
    if cfg.kind == "procedural":
        from neuraltex.data.datasets import ProceduralTextures

        families = list(cfg.families) if cfg.families else None
        ds = ProceduralTextures(total_items, size=cfg.size, seed=cfg.seed, families=families,
                                augment=augment)
        if cfg.get("cache"):  # the first items read from a folder written beforehand
            from neuraltex.data.cache import CachedTextures

            return CachedTextures(ds, cfg.cache)
        return ds
    if cfg.kind == "folder":
        from neuraltex.data.datasets import ImageFolderTextures

        return ImageFolderTextures(cfg.root, size=cfg.size, augment=augment)
    raise ValueError(f"unknown data.kind {cfg.kind!r}")


def data_workers(dataset: Dataset, workers: int) -> int:
    """``data.num_workers``, or 0 when every item of the run is read from a data cache: a
    worker would only copy memory-mapped arrays through a pipe (full 64 px step 0.347 s
    with one, 0.329 s without; docs/training_speed.md)."""
    from neuraltex.data.cache import CachedTextures

    if isinstance(dataset, CachedTextures) and dataset.filled >= len(dataset):
        return 0
    return workers


class StepSampler(Sampler[int]):
    """Indices of the batches for steps start, start+1, ... of one rank (wrapping around)."""

    def __init__(self, length: int, batch: int, start_step: int, rank: int = 0,
                 world: int = 1) -> None:
        self.length, self.batch, self.start = length, batch, start_step
        self.rank, self.world = rank, world

    def __iter__(self) -> Iterator[int]:
        step = self.start
        while True:
            base = (step * self.world + self.rank) * self.batch
            for i in range(self.batch):
                yield (base + i) % self.length
            step += 1

    def __len__(self) -> int:  # endless in practice; DataLoader only needs a number
        return 2**62


def batches(dataset: Dataset, batch: int, start_step: int, rank: int, world: int,
            workers: int) -> Iterator[dict]:
    sampler = StepSampler(len(dataset), batch, start_step, rank, world)
    loader = DataLoader(dataset, batch_size=batch, sampler=sampler, num_workers=workers,
                        collate_fn=_collate, persistent_workers=workers > 0)
    return iter(loader)


def _collate(items: list[dict]) -> dict:
    out = {"image": torch.stack([it["image"] for it in items])}
    if all("mask" in it for it in items):
        out["mask"] = torch.stack([it["mask"] for it in items])
    return out


def crop_batch(images: torch.Tensor, labels: torch.Tensor | None, size: int | None,
               generator: torch.Generator) -> tuple[torch.Tensor, torch.Tensor | None]:
    """One random size x size crop per image (and its label map): training on crops keeps the
    textons at the scale of the full images while the step costs a crop's pixels.
    images (B, 3, H, W), labels (B, H, W) or None."""
    from neuraltex.discriminators import random_crops

    if not size or size >= min(images.shape[-2:]):
        return images, labels
    stack = images if labels is None else torch.cat([images, labels[:, None].to(images)], 1)
    out = random_crops(stack, size, 1, generator=generator)  # (B, 3 [+ 1], size, size)
    if labels is None:
        return out, None
    return out[:, :3], out[:, 3].round().to(labels.dtype)
