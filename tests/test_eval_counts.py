"""scripts/eval_counts.py: the hand counts it reads and how it counts segments."""

import csv
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import eval_counts  # noqa: E402


def test_hand_counts_name_shipped_textures_and_say_how():
    with open(ROOT / "data" / "real_textures" / "counts.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) >= 2
    for r in rows:
        assert (ROOT / "data" / "real_textures" / r["file"]).is_file()
        assert int(r["elements"]) > 0 and len(r["how counted"]) > 20


def test_segments_counts_only_big_enough_labels_and_skips_no_texton():
    labels = np.zeros((100, 100), np.int64)
    labels[:50, :50] = 1
    labels[50:, 50:] = 2
    labels[0, 99] = 3  # one pixel: below MIN_SHARE (10 of 10,000)
    assert eval_counts.segments(labels, skip_zero=True) == 2
    assert eval_counts.segments(labels, skip_zero=False) == 3  # 0 is a segment of its own


def test_picture_row_shows_the_picture_then_each_methods_segments():
    rng = np.random.default_rng(0)
    image = rng.random((8, 10, 3))
    labels = np.zeros((8, 10), np.int64)
    labels[:, 5:] = 3
    row = eval_counts.picture_row(image, {"E_s": labels, "kmeans": labels},
                                  {"E_s": (None, True), "kmeans": (None, False)})
    assert row.shape == (8, 30, 3) and row.dtype == np.uint8
    assert np.array_equal(row[:, :10], (image * 255).astype(np.uint8))  # the picture first
    grey = (image.mean(2) * 255).astype(np.uint8)
    e_s, km = row[:, 10:20].astype(int), row[:, 20:].astype(int)
    assert np.abs(e_s[:, :5] - grey[:, :5, None]).max() <= 1  # E_s label 0: no texton, grey
    assert np.abs(km[:, :5] - grey[:, :5, None]).max() > 20  # k-means' 0 is a segment
    assert np.abs(e_s[:, 5:] - grey[:, 5:, None]).max() > 20  # segment 3 coloured
