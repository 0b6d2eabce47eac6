import numpy as np
import pytest
import torch
from PIL import Image
from torch.utils.data import DataLoader

from neuraltex.data.augment import Augment
from neuraltex.data.datasets import (
    ImageFolderTextures,
    InfiniteProceduralTextures,
    ProceduralTextures,
)
from neuraltex.data.generator import generate
from neuraltex.errors import InputError


def test_procedural_item():
    ds = ProceduralTextures(5, size=32, families=["leaves", "bricks"])
    item = ds[1]
    assert item["image"].shape == (3, 32, 32) and item["image"].dtype == torch.float32
    assert item["mask"].shape == (32, 32) and item["mask"].dtype == torch.int64
    assert item["family"] == "bricks" and item["count"] == int(item["mask"].max())
    s = generate(1, 0, 32, family="bricks")
    np.testing.assert_array_equal(item["mask"].numpy(), s.mask)
    with pytest.raises(IndexError):
        ds[5]


def test_procedural_augmented_and_collated():
    ds = ProceduralTextures(4, size=32, augment=Augment(hist_p=1.0), reference_size=16)
    batch = next(iter(DataLoader(ds, batch_size=4)))
    assert batch["image"].shape == (4, 3, 32, 32) and batch["mask"].shape == (4, 32, 32)
    again = ds[2]
    torch.testing.assert_close(batch["image"][2], again["image"])  # deterministic
    ds.epoch = 1
    assert not torch.equal(ds[2]["image"], again["image"])  # new epoch, new augmentation


def test_infinite_stream_matches_indexed():
    stream = iter(InfiniteProceduralTextures(size=32, start=3))
    first, second = next(stream), next(stream)
    assert first["index"] == 3 and second["index"] == 4
    torch.testing.assert_close(first["image"], ProceduralTextures(10, size=32)[3]["image"])


def test_reserved_seed_and_bad_args():
    with pytest.raises(InputError):
        ProceduralTextures(4, seed=2_000_003)
    with pytest.raises(InputError):
        ProceduralTextures(0)
    with pytest.raises(InputError):
        ProceduralTextures(4, families=["nope"])


def test_image_folder(tmp_path):
    rng = np.random.default_rng(0)
    for name in ("a.png", "b.JPG"):
        Image.fromarray(rng.integers(0, 255, (40, 60, 3), dtype=np.uint8)).save(tmp_path / name)
    (tmp_path / "notes.txt").write_text("not an image")
    ds = ImageFolderTextures(tmp_path, size=24, crops_per_image=3, augment=Augment())
    assert len(ds) == 6
    item = ds[4]
    assert item["image"].shape == (3, 24, 24) and "mask" not in item
    assert 0.0 <= float(item["image"].min()) and float(item["image"].max()) <= 1.0
    torch.testing.assert_close(ds[4]["image"], item["image"])
    assert next(iter(DataLoader(ds, batch_size=6)))["image"].shape == (6, 3, 24, 24)


def test_image_folder_errors(tmp_path):
    with pytest.raises(InputError):
        ImageFolderTextures(tmp_path / "missing")
    with pytest.raises(InputError):
        ImageFolderTextures(tmp_path)  # empty
    (tmp_path / "broken.png").write_bytes(b"not a png")
    with pytest.raises(InputError):
        ImageFolderTextures(tmp_path)[0]
