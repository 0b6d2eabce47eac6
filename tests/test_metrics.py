import numpy as np
import pytest
from sklearn.metrics import adjusted_rand_score

from neuraltex.metrics import (
    adjusted_rand_index,
    boundaries,
    boundary_f1,
    count_error,
    foreground_ari,
    iou_matrix,
    matched_miou,
    predicted_count,
    texton_scores,
)


@pytest.fixture
def gt():
    # 0 background, 4 separated square textons on a 24x24 image
    m = np.zeros((24, 24), np.int64)
    m[2:8, 2:8], m[2:8, 14:20], m[14:20, 2:8], m[14:20, 14:20] = 1, 2, 3, 4
    return m


def test_perfect_prediction(gt):
    s = texton_scores(gt.copy(), gt)
    assert s == pytest.approx(dict(miou=1.0, ari=1.0, count_err=0.0, boundary_f1=1.0))


def test_relabelled_prediction_scores_the_same(gt):
    perm = np.array([17, 3, 99, 5, 42])  # background -> 17, texton k -> perm[k]
    s = texton_scores(perm[gt], gt)
    assert s == pytest.approx(texton_scores(gt.copy(), gt))


def test_single_segment_scores_low(gt):
    s = texton_scores(np.zeros_like(gt), gt)
    assert s["miou"] == pytest.approx(36 / 576 / 4)  # one texton matched, IoU 36/576
    assert s["ari"] == pytest.approx(0.0)
    assert s["count_err"] == pytest.approx(1.0)  # no segment lies mostly on textons
    assert s["boundary_f1"] == 0.0


def test_random_prediction_scores_low(gt):
    big = np.kron(gt, np.ones((4, 4), np.int64))  # 96 x 96, textons of 24 px
    pred = np.random.default_rng(0).integers(0, 5, big.shape)
    s = texton_scores(pred, big)
    assert s["miou"] < 0.15 and abs(s["ari"]) < 0.05 and s["boundary_f1"] < 0.5


def test_hand_made_values():
    gt = np.array([[1, 1, 0, 2],
                   [1, 1, 0, 2]])
    pred = np.array([[5, 6, 6, 6],
                     [5, 6, 6, 6]])
    iou = iou_matrix(pred, gt)  # rows: textons 1, 2; cols: segments 5, 6
    np.testing.assert_allclose(iou, [[2 / 4, 2 / 8], [0.0, 2 / 6]])
    assert matched_miou(pred, gt) == pytest.approx((0.5 + 1 / 3) / 2)
    # merge texton 2 and half of texton 1: ARI on the 6 foreground pixels
    fg = gt > 0
    assert foreground_ari(pred, gt) == pytest.approx(adjusted_rand_score(gt[fg], pred[fg]))
    # segment 5 is all texton (2/2), segment 6 is 4/6 texton: both count
    assert predicted_count(pred, gt) == 2 and count_error(pred, gt) == 0.0
    # a segment that is half background does not count as a texton
    assert predicted_count(np.array([[5, 5, 6, 6], [5, 5, 6, 6]]), gt) == 1
    assert count_error(pred, gt, count=4) == pytest.approx(1.0)


def test_hungarian_is_one_to_one():
    gt = np.array([[1, 1, 2, 2]])
    pred = np.zeros_like(gt)  # one segment cannot match both textons
    assert matched_miou(pred, gt) == pytest.approx(0.5 / 2)


def test_ari_matches_sklearn():
    rng = np.random.default_rng(3)
    for _ in range(5):
        a, b = rng.integers(0, 4, 200), rng.integers(0, 6, 200)
        assert adjusted_rand_index(a, b) == pytest.approx(adjusted_rand_score(a, b))


def test_boundary_f1_tolerance(gt):
    shifted = np.roll(gt, 3, axis=1)  # vertical boundaries 3 px off
    assert boundary_f1(shifted, gt, tolerance=3) == pytest.approx(1.0)
    assert boundary_f1(shifted, gt, tolerance=1) < 0.7
    assert boundaries(np.zeros((3, 3))).sum() == 0


def test_no_texton_is_nan_and_shape_mismatch_raises():
    assert np.isnan(matched_miou(np.zeros((4, 4)), np.zeros((4, 4), np.int64)))
    with pytest.raises(ValueError):
        matched_miou(np.zeros((4, 5)), np.zeros((4, 4)))
