"""torch Datasets: procedural textures (indexed or endless) and a folder of user images.

Items are dicts. Procedural: ``image`` (3, H, W) float32 in [0, 1], ``mask`` (H, W)
int64 (0 = background, 1..K textons), ``count`` int, ``family`` str, ``index`` int.
Image folder: ``image`` and ``index`` only (user images have no ground truth).
Every item is a pure function of (seed, epoch, index), in any worker.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import torch
from PIL import Image, UnidentifiedImageError
from torch.utils.data import Dataset, IterableDataset, get_worker_info

from neuraltex.data.augment import Augment
from neuraltex.data.families import FAMILY_NAMES
from neuraltex.data.generator import generate
from neuraltex.data.splits import check_training_seed
from neuraltex.errors import InputError

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
_AUG_STREAM = 7  # extra key so augmentation draws never reuse the generator's stream
REFERENCE_POOL = 64  # distinct histogram references per stream
REFERENCE_OFFSET = 900_000_000


def _to_item(image: np.ndarray, mask: np.ndarray | None, **meta) -> dict:
    item = {"image": torch.from_numpy(np.ascontiguousarray(image.transpose(2, 0, 1)))}
    if mask is not None:
        item["mask"] = torch.from_numpy(mask.astype(np.int64))
        item["count"] = int(mask.max())
    return item | meta


@functools.lru_cache(maxsize=REFERENCE_POOL)
def _reference(seed: int, index: int, size: int) -> np.ndarray:
    # Histogram references come from a fixed pool of samples of the same stream (far from
    # the training indices), memoized per worker: rendering a fresh one per item would
    # almost double the cost of an item.
    return generate(REFERENCE_OFFSET + index, seed, size).image


class ProceduralTextures(Dataset):
    """``length`` procedural samples of training stream ``seed`` at ``size`` px.

    ``families`` restricts (round-robin) to some families; ``augment`` (None = off) is
    applied with a histogram reference rendered at ``reference_size`` px from the same
    stream. Set ``epoch`` between epochs to draw new augmentations of the same textures.
    """

    def __init__(self, length: int, size: int = 128, seed: int = 0,
                 families: Sequence[str] | None = None, augment: Augment | None = None,
                 reference_size: int = 64, epoch: int = 0):
        check_training_seed(seed)
        if length < 1:
            raise InputError(f"length must be >= 1, got {length}")
        for f in families or ():
            if f not in FAMILY_NAMES:
                raise InputError(f"unknown family {f!r}; choose from {', '.join(FAMILY_NAMES)}")
        self.length, self.size, self.seed = length, size, seed
        self.families = list(families) if families else None
        self.augment, self.reference_size, self.epoch = augment, reference_size, epoch

    def __len__(self) -> int:
        return self.length

    def __getitem__(self, index: int) -> dict:
        if not 0 <= index < self.length:
            raise IndexError(index)
        return self.item(index)

    def item(self, index: int) -> dict:
        family = self.families[index % len(self.families)] if self.families else None
        s = generate(index, self.seed, self.size, family=family)
        image, mask = s.image, s.mask
        if self.augment is not None:
            rng = np.random.default_rng([self.seed, index, self.epoch, _AUG_STREAM])
            ref = None
            if self.augment.hist_p > 0:
                ref = _reference(self.seed, int(rng.integers(REFERENCE_POOL)),
                                 self.reference_size)
            image, mask = self.augment(rng, image, mask, ref)
        return _to_item(image, mask, family=s.family, index=index)


class InfiniteProceduralTextures(IterableDataset):
    """An endless stream of procedural samples; DataLoader workers take interleaved indices.

    Same arguments as :class:`ProceduralTextures` (minus ``length``), plus ``start``.
    """

    def __init__(self, size: int = 128, seed: int = 0, families: Sequence[str] | None = None,
                 augment: Augment | None = None, reference_size: int = 64, start: int = 0):
        self.base = ProceduralTextures(1, size, seed, families, augment, reference_size)
        self.start = start

    def __iter__(self) -> Iterator[dict]:
        info = get_worker_info()
        worker, n_workers = (info.id, info.num_workers) if info else (0, 1)
        index = self.start + worker
        while True:
            yield self.base.item(index)
            index += n_workers


def list_images(root: str | Path) -> list[Path]:
    """PNG/JPG files under ``root`` (recursive, sorted)."""
    root = Path(root)
    if not root.is_dir():
        raise InputError(f"image folder not found: {root}")
    files = sorted(p for p in root.rglob("*") if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise InputError(f"no .png/.jpg images in {root}")
    return files


def load_rgb(path: Path) -> np.ndarray:
    """Read an image as (H, W, 3) float32 in [0, 1]; InputError if unreadable."""
    try:
        with Image.open(path) as im:
            return np.asarray(im.convert("RGB"), np.float32) / 255.0
    except (UnidentifiedImageError, OSError) as exc:
        raise InputError(f"cannot read image {path}: {exc}") from exc


class ImageFolderTextures(Dataset):
    """Random square crops of the user's PNG/JPG textures, resized to ``size``, augmented.

    Each image gives ``crops_per_image`` items. The crop side is a random fraction
    ``crop_scale`` of the image's short side; ``augment`` matches histograms against a
    crop of another random image of the folder.
    """

    def __init__(self, root: str | Path, size: int = 128, crops_per_image: int = 16,
                 seed: int = 0, augment: Augment | None = None,
                 crop_scale: tuple[float, float] = (0.5, 1.0), epoch: int = 0):
        self.files = list_images(root)
        if crops_per_image < 1:
            raise InputError(f"crops_per_image must be >= 1, got {crops_per_image}")
        self.size, self.crops, self.seed = size, crops_per_image, seed
        self.augment, self.crop_scale, self.epoch = augment, crop_scale, epoch

    def __len__(self) -> int:
        return len(self.files) * self.crops

    def _crop(self, rng: np.random.Generator, path: Path, size: int) -> np.ndarray:
        image = load_rgb(path)
        h, w = image.shape[:2]
        side = max(1, int(round(min(h, w) * rng.uniform(*self.crop_scale))))
        y0, x0 = int(rng.integers(0, h - side + 1)), int(rng.integers(0, w - side + 1))
        crop = Image.fromarray((image[y0:y0 + side, x0:x0 + side] * 255).astype(np.uint8))
        crop = crop.resize((size, size), Image.Resampling.BILINEAR, reducing_gap=2.0)
        return np.asarray(crop, np.float32) / 255.0  # (size, size, 3)

    def __getitem__(self, index: int) -> dict:
        if not 0 <= index < len(self):
            raise IndexError(index)
        rng = np.random.default_rng([self.seed, index, self.epoch, _AUG_STREAM])
        image = self._crop(rng, self.files[index // self.crops], self.size)
        if self.augment is not None:
            ref = None
            if self.augment.hist_p > 0:
                other = self.files[int(rng.integers(len(self.files)))]
                ref = self._crop(rng, other, 64)
            image, _ = self.augment(rng, image, None, ref)
        return _to_item(image, None, index=index)
