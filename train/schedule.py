"""Loss-weight schedules: a number, or milestones [[step, value], ...] (appendix 7.7.2).

Milestone steps are multiplied by ``scale`` so a short CPU run keeps the paper's phases in
proportion (scale 0.02 turns the 5,000-step milestone into 100).
"""

from __future__ import annotations

from collections.abc import Sequence

Schedule = float | Sequence[Sequence[float]]  # a number, or [[step, value], ...]


def scheduled(value: Schedule, step: int, scale: float = 1.0) -> float:
    """Value in force at ``step``: the last milestone whose scaled step is <= step."""
    if isinstance(value, (int, float)):
        return float(value)
    current = None
    for milestone, v in sorted(value, key=lambda m: m[0]):
        if milestone * scale <= step or current is None:
            current = float(v)
    if current is None:
        raise ValueError("empty schedule")
    return current
