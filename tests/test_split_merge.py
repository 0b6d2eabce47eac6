"""neuraltex.split_merge: pieces of one element joined, neighbouring elements kept apart."""

import numpy as np
import pytest

from neuraltex.split_merge import merge_split


def _two_squares(grey_left: float, grey_right: float) -> tuple[np.ndarray, np.ndarray]:
    """(fine labels, grey picture) of two 10 x 10 squares side by side on a black ground:
    fine labels 0 the ground (no segment), 1 and 2 the halves of the left square, 3 the right
    square."""
    grey = np.zeros((20, 30))
    grey[5:15, 5:15] = grey_left
    grey[5:15, 15:25] = grey_right
    fine = np.zeros((20, 30), np.int64)
    fine[5:15, 5:10], fine[5:15, 10:15], fine[5:15, 15:25] = 1, 2, 3
    return fine, grey


def test_pieces_of_one_element_in_one_coarse_segment_are_joined():
    fine, grey = _two_squares(0.5, 0.5)
    coarse = np.where(fine > 0, 7, 0)  # the coarse run: one blob for everything
    out = merge_split(fine, coarse, grey)
    assert out[5, 5] == out[5, 14]  # the left square's halves: no edge between them
    assert out[5, 14] == out[5, 24]  # and the right square: flat grey, no edge either
    assert (out[fine == 0] == 0).all() and set(np.unique(out)) == {0, 1}


def test_an_edge_between_pieces_keeps_them_apart():
    fine, grey = _two_squares(0.3, 0.8)
    coarse = np.where(fine > 0, 7, 0)
    out = merge_split(fine, coarse, grey)
    assert out[5, 5] == out[5, 14]  # halves of one flat square: joined
    assert out[5, 14] != out[5, 24]  # an edge of 0.5 in grey between the squares
    assert set(np.unique(out)) == {0, 1, 2}


def test_pieces_the_coarse_run_keeps_apart_stay_apart():
    fine, grey = _two_squares(0.5, 0.5)
    coarse = fine.copy()  # the coarse run already splits the left square
    assert np.array_equal(merge_split(fine, coarse, grey), fine)
    # a piece whose pixels are mostly "no segment" in the coarse run has no home, and the
    # pieces either side of it do not touch
    coarse = np.where(fine == 2, 0, np.where(fine > 0, 7, 0))
    assert len(np.unique(merge_split(fine, coarse, grey))) == 4


def test_share_and_edge_thresholds():
    fine, grey = _two_squares(0.5, 0.5)
    coarse = np.where(fine > 0, 7, 0)
    coarse[5:15, 10:12] = 8  # 2 of the 5 columns of piece 2 lie in another coarse segment
    assert merge_split(fine, coarse, grey, share=0.5)[5, 12] == 1  # 60 % home: joined
    out = merge_split(fine, coarse, grey, share=0.7)
    assert out[5, 12] != out[5, 5]  # 60 % < 70 %: no home, stays apart
    fine, grey = _two_squares(0.3, 0.8)
    coarse = np.where(fine > 0, 7, 0)
    assert merge_split(fine, coarse, grey, edge=10.0)[5, 5] == merge_split(
        fine, coarse, grey, edge=10.0)[5, 24]  # no edge is strong enough: all joined


def test_labels_come_out_consecutive_and_shapes_are_checked():
    fine, grey = _two_squares(0.3, 0.8)
    out = merge_split(fine * 5 + 3 * (fine > 0), np.where(fine > 0, 2, 0), grey)
    assert set(np.unique(out)) == {0, 1, 2}
    full = np.where(fine > 0, fine, 4)  # no "no segment" pixel anywhere
    out = merge_split(full, np.ones_like(full), grey)
    assert out.min() == 1
    with pytest.raises(ValueError, match="one shape"):
        merge_split(fine, fine[:-1], grey)
