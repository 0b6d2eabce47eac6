"""scripts/eval_real.py's summary: the counts it prints name the textures they are made of."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import eval_real  # noqa: E402


def _row(swd_rec: float, swd_shuf: float, change: float) -> dict:
    row = {c: 1.0 for c in eval_real.COLS}
    row.update(swd_rec=swd_rec, swd_shuf=swd_shuf, change=change, moved=0.5)
    return row


def test_summary_names_the_reshuffles_over_the_bound_and_those_that_show():
    rows = [("brick", _row(0.010, 0.014, 0.004)),     # 1.4x: over the 1.25x bound
            ("coins", _row(0.030, 0.030, 0.017)),     # within, visibly changed
            ("ice", _row(0.004, 0.004, 0.000))]       # within, nothing moved
    lines = eval_real.summary(rows)
    shuffle = next(line for line in lines if line.startswith("reshuffle SWD"))
    assert shuffle.startswith("reshuffle SWD <= 1.25 x reconstruction SWD on 2/3 (over: brick);")
    visible = next(line for line in lines if line.startswith("within 1.25 x"))
    assert visible.endswith(": 1/3 (coins)")
    none_over = eval_real.summary(rows[1:])
    assert any(line.startswith("reshuffle SWD <= 1.25 x reconstruction SWD on 2/2;")
               for line in none_over)
