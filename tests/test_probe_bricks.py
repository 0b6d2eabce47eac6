"""scripts/probe_bricks.py: the bricks it reads from a photograph and how it scores segments."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import probe_bricks  # noqa: E402


def _wall() -> np.ndarray:
    """(H, W) 0 mortar, 1..6 bricks: two rows of three 10 x 20 bricks, 2 px joints."""
    wall = np.zeros((26, 70), np.int64)
    for r in range(2):
        for c in range(3):
            wall[2 + 12 * r: 12 + 12 * r, 2 + 22 * c: 22 + 22 * c] = 1 + 3 * r + c
    return wall


def test_photo_bricks_finds_the_dark_regions_between_light_joints():
    wall = _wall()
    picture = probe_bricks.flat(wall, np.random.default_rng(0)).mean(2)
    labels, ids = probe_bricks.photo_bricks(picture)
    assert len(ids) == 6
    for k in ids:  # each found region is one whole brick
        assert len(np.unique(wall[labels == k])) == 1


def test_own_segments_counts_bricks_with_a_segment_of_their_own():
    wall = _wall()
    ids = list(range(1, 7))
    assert probe_bricks.own_segments(wall, wall, ids) == 6
    merged = np.where(wall > 3, 4, wall)  # the lower row one segment: IoU 1/3 each
    assert probe_bricks.own_segments(merged, wall, ids) == 3
    assert probe_bricks.own_segments(np.zeros_like(wall), wall, ids) == 0
