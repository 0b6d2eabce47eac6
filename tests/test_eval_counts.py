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


def test_leopard_hand_count_follows_its_stated_rule():
    """counts.csv's leopard number is the rule it states (scripts/probe_spots.py): dark
    4-connected regions of grey < 80, border regions under half the median area left out
    (the by-eye check of each region is not repeated here)."""
    import probe_spots
    from PIL import Image

    with open(ROOT / "data" / "real_textures" / "counts.csv", newline="") as f:
        stated = {r["file"]: int(r["elements"]) for r in csv.DictReader(f)}
    grey = np.asarray(Image.open(ROOT / "data" / "real_textures" / "leopard.png")
                      .convert("RGB")).astype(float).mean(2) / 255
    labels, ids = probe_spots.spots(grey)
    assert labels.max() == 301  # 37 of them border slivers
    assert stated["leopard.png"] == len(ids) == 264
    assert all(labels[labels == k].size > 0 for k in ids)


def test_spots_leaves_out_only_small_border_regions():
    import probe_spots

    grey = np.ones((40, 40))
    for y, x in ((10, 10), (10, 25), (25, 10)):  # three 5 x 5 spots inside
        grey[y:y + 5, x:x + 5] = 0
    grey[25:27, 25:27] = 0  # a small one inside: kept
    grey[0:2, 30:32] = 0  # a small one on the border: a sliver
    grey[35:40, 0:5] = 0  # a full-size one on the border: kept
    labels, ids = probe_spots.spots(grey)
    assert labels.max() == 6 and len(ids) == 5
    assert labels[0, 30] not in ids and labels[26, 26] in ids and labels[39, 0] in ids


def test_summary_averages_the_ratio_and_the_count_error():
    text = eval_counts.summary({"a": [0.5, 1.5], "b": [1.0, 2.0]})
    mean, error = text.splitlines()
    assert mean == "| **mean per element** | | 1.00x | 1.50x |"
    assert error == "| **mean count error** | | 50 % | 50 % |"  # 1.00x on average, never right
