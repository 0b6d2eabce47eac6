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
