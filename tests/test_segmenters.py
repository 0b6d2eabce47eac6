"""Classical segments for textons (neuraltex.segmenters): large segments cut into pieces."""

import numpy as np


def test_large_segments_are_cut_into_compact_pieces_but_a_backdrop_stays_whole():
    from neuraltex.segmenters import split_large

    labels = np.zeros((64, 64), np.int64)     # a backdrop (label 0) ...
    labels[8:32, 8:32] = 1                     # ... a 576 px segment (under 1/4 of the image)
    labels[48:52, 48:52] = 2                   # ... and a small one
    out = split_large(labels, max_segments=400, share=1 / 32, floor=0)   # limit 128 px
    assert len(np.unique(out[labels == 0])) == 1 and len(np.unique(out[labels == 2])) == 1
    pieces = np.unique(out[labels == 1])
    assert 4 <= len(pieces) <= 5                                # about 576 / 128
    sizes = np.bincount(out[labels == 1])[pieces]
    assert sizes.max() <= 3 * 128
    assert len(np.unique(out)) == out.max() + 1                # dense labels
    capped = split_large(labels, max_segments=5, share=1 / 32, floor=0)
    assert capped.max() + 1 == 5                               # never over the cap
    assert np.array_equal(split_large(labels, 400, share=1 / 32, floor=600), labels)  # floor
