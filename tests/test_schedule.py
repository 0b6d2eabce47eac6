"""train/schedule.py and the per-step loss settings built on it (appendix 7.7.2)."""

import pytest

from train.loss_config import LossConfig
from train.schedule import scheduled


def test_a_number_is_constant():
    assert scheduled(0.3, 0) == scheduled(0.3, 10**6) == 0.3
    assert isinstance(scheduled(2, 5), float)


def test_milestones_switch_at_their_step_in_any_order():
    s = [[5000, 0.2], [0, 100.0], [1000, 1.0]]  # unsorted on purpose
    assert [scheduled(s, k) for k in (0, 999, 1000, 4999, 5000, 10**6)] == [
        100.0, 100.0, 1.0, 1.0, 0.2, 0.2]


def test_scale_shrinks_the_milestones_and_a_late_first_milestone_holds_from_zero():
    s = [[0, 0.008], [5000, 0.08]]
    assert scheduled(s, 99, scale=0.02) == 0.008 and scheduled(s, 100, scale=0.02) == 0.08
    assert scheduled([[10, 3.0]], 0) == 3.0  # before the first milestone: its value
    with pytest.raises(ValueError, match="empty"):
        scheduled([], 0)


def test_step_settings_follow_the_loss_config():
    loss = LossConfig(existence_warmup=100, segmenter_warmup=50)
    early, late = loss.at(0, scale=0.02), loss.at(5000, scale=0.02)
    assert early.compact == 100.0 and late.compact == 0.2  # [[0, 100], [1000, 1], [5000, 0.2]]
    assert early.patch_size == 2 and loss.at(40000).patch_size == 4
    assert isinstance(late.patch_size, int)
    assert (early.existence, early.segmenter_only) == ("all", True)
    assert (late.existence, late.segmenter_only) == ("sample", False)
    assert set(late.scalars()) == {"entropy", "compact", "csis", "texture", "gan", "pgan",
                                   "mask", "patch_size"}
