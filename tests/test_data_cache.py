"""The training data cache (neuraltex/data/cache.py): items written once, read back."""

import json

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf

from neuraltex.data import cache
from neuraltex.data.augment import Augment
from neuraltex.data.datasets import ProceduralTextures
from neuraltex.errors import InputError


def _ds(seed: int = 0) -> ProceduralTextures:
    return ProceduralTextures(100, size=32, seed=seed, augment=Augment())


def test_cached_items_equal_the_rendered_ones_and_later_items_are_rendered(tmp_path):
    ds = _ds()
    assert cache.write_cache(ds, tmp_path, 6, workers=0, progress=False) == 6
    cached = cache.CachedTextures(ds, tmp_path)
    assert len(cached) == 100
    for i in (0, 3, 5, 6, 7):
        a, b = cached[i], ds.item(i)
        assert set(a) == set(b) and a["image"].dtype == torch.float32
        assert (a["image"] - b["image"]).abs().max() <= 0.5 / 255 + 1e-6  # 8-bit
        assert torch.equal(a["mask"], b["mask"]) and a["mask"].dtype == torch.int64
        assert (a["count"], a["family"], a["index"]) == (b["count"], b["family"], i)
    assert torch.equal(cached[7]["image"], ds.item(7)["image"])  # beyond the cache: rendered
    with pytest.raises(IndexError):
        cached[100]


def test_writing_resumes_a_partial_cache(tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CHUNK", 3)
    ds = _ds()
    cache.write_cache(ds, tmp_path / "whole", 7, workers=0, progress=False)
    part = tmp_path / "part"
    cache.write_cache(ds, part, 7, workers=0, progress=False)
    meta = json.loads((part / "meta.json").read_text())
    meta["filled"] = 3  # as if stopped after the first chunk
    (part / "meta.json").write_text(json.dumps(meta))
    images = np.load(part / "images.npy", mmap_mode="r+")
    images[3:] = 0
    images.flush()
    assert cache.CachedTextures(ds, part).filled == 3
    assert cache.write_cache(ds, part, 7, workers=0, progress=False) == 7
    assert np.array_equal(np.load(part / "images.npy"), np.load(tmp_path / "whole" / "images.npy"))
    with pytest.raises(InputError, match="started with 7 items"):
        cache.write_cache(ds, part, 9, workers=0, progress=False)


def test_a_cache_of_other_items_is_refused(tmp_path, monkeypatch):
    cache.write_cache(_ds(), tmp_path, 2, workers=0, progress=False)
    with pytest.raises(InputError, match="seed differ"):
        cache.CachedTextures(_ds(seed=1), tmp_path)
    with pytest.raises(InputError, match="augment differ"):
        cache.CachedTextures(ProceduralTextures(100, size=32), tmp_path)
    monkeypatch.setattr(cache, "code_hash", lambda: "another generator")
    with pytest.raises(InputError, match="code changed"):
        cache.CachedTextures(_ds(), tmp_path)
    with pytest.raises(InputError, match="no meta.json"):
        cache.CachedTextures(_ds(), tmp_path / "missing")


def test_cli_writes_a_cache_and_rejects_bad_arguments(tmp_path, capsys):
    assert cache.main([str(tmp_path / "c"), "--items", "3", "--size", "24", "--workers",
                       "0"]) == 0
    assert "wrote 3 items" in capsys.readouterr().out
    assert np.load(tmp_path / "c" / "images.npy").shape == (3, 24, 24, 3)
    assert cache.main([str(tmp_path / "d"), "--items", "0"]) == 2
    assert cache.main([str(tmp_path / "d"), "--items", "3", "--size", "4"]) == 2
    (tmp_path / "f").write_text("x")
    assert cache.main([str(tmp_path / "f"), "--items", "3"]) == 2
    assert "not a folder" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cache.main(["--help"])
    assert "--items" in capsys.readouterr().out


def test_training_reads_the_cache_given_in_the_data_config(tmp_path):
    from train.data import build_dataset, data_workers

    cfg = OmegaConf.create({"kind": "procedural", "seed": 0, "size": 32, "families": None,
                            "augment": True, "cache": str(tmp_path)})
    cache.write_cache(build_dataset(OmegaConf.merge(cfg, {"cache": None}), 50), tmp_path, 2,
                      workers=0, progress=False)
    ds = build_dataset(cfg, 50)
    assert isinstance(ds, cache.CachedTextures) and ds.filled == 2
    assert torch.equal(ds[0]["mask"], ds.ds.item(0)["mask"])
    # a worker only where items are still rendered: not for a run the cache covers
    assert data_workers(ds, 1) == 1 and data_workers(build_dataset(cfg, 2), 1) == 0
    assert data_workers(build_dataset(OmegaConf.merge(cfg, {"cache": None}), 2), 1) == 1


def test_a_damaged_cache_is_one_error(tmp_path):
    ds = _ds()
    cache.write_cache(ds, tmp_path, 3, workers=0, progress=False)
    meta = json.loads((tmp_path / "meta.json").read_text())
    (tmp_path / "meta.json").write_text(json.dumps({**meta, "filled": 5}))  # beyond the arrays
    with pytest.raises(InputError, match="damaged"):
        cache.CachedTextures(ds, tmp_path)
    (tmp_path / "meta.json").write_text(json.dumps(meta))
    np.save(tmp_path / "families.npy", np.full(3, 200, np.uint8))
    with pytest.raises(InputError, match="unknown family"):
        cache.CachedTextures(ds, tmp_path)
    (tmp_path / "masks.npy").write_bytes(b"not an array")
    with pytest.raises(InputError, match="unreadable"):
        cache.CachedTextures(ds, tmp_path)
    with pytest.raises(InputError, match="unreadable"):  # nor resumed
        cache.write_cache(ds, tmp_path, 3, workers=0, progress=False)
    for text in ("{", "[1, 2]"):
        (tmp_path / "meta.json").write_text(text)
        with pytest.raises(InputError, match="meta.json"):
            cache.CachedTextures(ds, tmp_path)


def test_a_failed_write_is_one_error_and_the_written_chunks_resume(tmp_path, monkeypatch):
    monkeypatch.setattr(cache, "CHUNK", 2)
    real, calls = cache.write_text_atomic, []

    def full_disk(path, text):  # the second chunk's meta.json finds the disk full
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        real(path, text)

    monkeypatch.setattr(cache, "write_text_atomic", full_disk)
    with pytest.raises(InputError, match="after 2 items .*No space left.*resumes"):
        cache.write_cache(_ds(), tmp_path, 5, workers=0, progress=False)
    assert cache.CachedTextures(_ds(), tmp_path).filled == 2  # the first chunk counts
    assert cache.write_cache(_ds(), tmp_path, 5, workers=0, progress=False) == 5
    assert cache.CachedTextures(_ds(), tmp_path).filled == 5
