"""neuraltex.tiled_segments: the labels of overlapping tiles merged into one labelling."""

import numpy as np
import pytest

from neuraltex.tiled_segments import merge_tiles, tile_origins


def tiled_labels(segment, image: np.ndarray, tile: int, overlap: int) -> np.ndarray:
    """``segment`` (h, w, 3) -> (h, w) run on the tiles of ``image`` row by row, merged."""
    ys = tile_origins(image.shape[0], tile, overlap)
    xs = tile_origins(image.shape[1], tile, overlap)
    parts = {(i, j): segment(image[y:y + tile, x:x + tile])
             for i, y in enumerate(ys) for j, x in enumerate(xs)}
    return merge_tiles(parts, image.shape[:2], ys, xs)


def test_tile_origins_cover_the_side_and_end_flush():
    assert tile_origins(100, 128, 32) == [0]
    starts = tile_origins(300, 128, 32)
    assert starts[0] == 0 and starts[-1] == 300 - 128
    assert all(0 < b - a <= 96 for a, b in zip(starts, starts[1:], strict=False))


def _squares(side: int = 96, size: int = 8, gap: int = 4) -> np.ndarray:
    """(side, side) 0 background, 1.. squares of ``size`` px ``gap`` px apart."""
    truth = np.zeros((side, side), np.int64)
    k = 0
    for y in range(gap, side - size, size + gap):
        for x in range(gap, side - size, size + gap):
            k += 1
            truth[y:y + size, x:x + size] = k
    return truth


def _oracle(truth: np.ndarray, tile: int, overlap: int):
    """A segmenter that returns the true segments of each tile, numbered as the tile sees
    them (tiles come row by row, as tiled_labels visits them), and the tiles it was asked."""
    calls = []
    origins = [(y, x) for y in tile_origins(truth.shape[0], tile, overlap)
               for x in tile_origins(truth.shape[1], tile, overlap)]

    def segment(part_image: np.ndarray) -> np.ndarray:
        y, x = origins[len(calls)]
        calls.append((y, x))
        part = truth[y:y + part_image.shape[0], x:x + part_image.shape[1]]
        _, local = np.unique(part, return_inverse=True)
        return np.where(part > 0, local.reshape(part.shape) + 100 * len(calls), 0)

    return segment, calls, origins


def test_elements_cut_by_tile_borders_are_joined_again():
    """The oracle on tiles that cut many squares: every square comes back as exactly one
    segment of its own."""
    truth = _squares()
    image = np.zeros(truth.shape + (3,))
    segment, calls, origins = _oracle(truth, 40, 12)
    labels = tiled_labels(segment, image, 40, 12)
    assert len(calls) == len(origins) > 4
    cut = sum(len(np.unique(truth[y:y + 40, x:x + 40])) for y, x in origins) - len(origins)
    assert cut > truth.max()  # squares are seen by several tiles
    for k in range(1, truth.max() + 1):
        assert len(np.unique(labels[truth == k])) == 1  # one segment per square ...
    found = {int(labels[truth == k][0]) for k in range(1, truth.max() + 1)}
    assert len(found) == truth.max() and 0 not in found  # ... each its own
    assert (labels[truth == 0] == 0).all()  # no segment stays no segment


def test_a_segment_larger_than_the_tiles_comes_back_whole():
    """A background spanning every tile is kept by each of them; the pieces are joined where
    the tiles overlap, and the squares on it stay apart."""
    truth = _squares() + 1  # 1: the background around the squares, a segment too
    segment, _, _ = _oracle(truth, 40, 12)
    labels = tiled_labels(segment, np.zeros(truth.shape + (3,)), 40, 12)
    assert len(np.unique(labels[truth == 1])) == 1
    assert len(np.unique(labels)) == truth.max()  # the background and every square


def test_nothing_segmented_stays_nothing_and_bad_overlap_is_refused():
    image = np.zeros((70, 90, 3))
    assert (tiled_labels(lambda t: np.zeros(t.shape[:2], np.int64), image, 32, 8) == 0).all()
    with pytest.raises(ValueError, match="overlap"):
        tile_origins(90, 32, 32)


def test_pixels_no_kept_segment_claims_go_to_the_nearest_claimed_one():
    """The first tile sees a sliver across its core's edge (x 28-39: its centre outside that
    core, so not kept); in the next tile the same pixels x 28-31 belong to a piece whose
    centre is outside that tile's core too. Those pixels are claimed by no kept segment: they
    join the segments next to them instead of coming back as a label of their own."""
    truth = np.zeros((64, 64), np.int64)
    truth[:, :32], truth[:, 32:] = 1, 2  # two halves
    origins = [(y, x) for y in tile_origins(64, 40, 16) for x in tile_origins(64, 40, 16)]
    assert [x for _, x in origins[:2]] == [0, 24]  # cores: x < 32 and x >= 32
    tiles = []

    def segment(part: np.ndarray) -> np.ndarray:
        y, x = origins[len(tiles)]
        tiles.append((y, x))
        out = truth[y:y + 40, x:x + 40].copy()
        if x == 0:
            out[:, 28:40] = 7  # the sliver
        return out

    labels = tiled_labels(segment, np.zeros((64, 64, 3)), 40, 16)
    assert len(np.unique(labels)) == 2  # no third label from the sliver
    assert (labels[:, :28] == labels[0, 0]).all() and (labels[:, 32:] == labels[0, 63]).all()
