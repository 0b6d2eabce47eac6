"""Score texton extraction methods on a split: per-sample scores, per-family tables, tuning."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from tqdm import tqdm

from neuraltex.baselines import Method, Segmenter
from neuraltex.data.families import FAMILIES, FAMILY_NAMES
from neuraltex.data.generator import Sample
from neuraltex.metrics import METRICS, texton_scores

GROUPS = ("easy", "hard", "overall")


def score(segment: Segmenter, samples: Sequence[Sample], desc: str = "",
          progress: bool = True) -> list[dict]:
    """One row per sample: family, hard flag, size and every metric of ``METRICS``."""
    rows = []
    for s in tqdm(samples, desc=desc, leave=False, disable=not progress):
        pred = np.asarray(segment(s.image))
        if pred.shape != s.mask.shape:
            raise ValueError(f"method returned {pred.shape} for a {s.mask.shape} image")
        rows.append(dict(family=s.family, hard=s.hard, size=s.mask.shape[0],
                         **texton_scores(pred, s.mask)))
    return rows


def aggregate(rows: Sequence[dict], metric: str = "miou") -> dict[str, float]:
    """Mean ``metric`` per family present, plus 'easy', 'hard' and 'overall' (nan-aware).

    'easy'/'hard'/'overall' average over images, so families weigh by their image count
    (equal in the round-robin splits).
    """
    out = {}
    for name in FAMILY_NAMES:
        vals = [r[metric] for r in rows if r["family"] == name]
        if vals:
            out[name] = float(np.nanmean(vals))
    for group in GROUPS:
        vals = [r[metric] for r in rows
                if group == "overall" or r["hard"] == (group == "hard")]
        out[group] = float(np.nanmean(vals)) if vals else float("nan")
    return out


def tune(method: Method, samples: Sequence[Sample], progress: bool = True):
    """Pick ``method``'s main parameter maximising overall matched mIoU on ``samples``.

    Returns (best value, {value: overall mIoU}).
    """
    curve = {}
    for value in method.grid:
        rows = score(method.build(value), samples, f"tune {method.name}={value}", progress)
        curve[value] = aggregate(rows)["overall"]
    best = max(curve, key=lambda v: curve[v])
    return best, curve


def family_table(results: dict[str, list[dict]], metric: str = "miou") -> str:
    """Markdown table: families (tagged easy/hard) + groups as rows, methods as columns."""
    names = list(results)
    agg = {m: aggregate(rows, metric) for m, rows in results.items()}
    lines = ["| family | " + " | ".join(names) + " |",
             "|---|" + "---:|" * len(names)]
    present = [f for f in FAMILY_NAMES if any(f in a for a in agg.values())]
    for f in [*present, *GROUPS]:
        label = f"{f} ({'hard' if FAMILIES[f].hard else 'easy'})" if f in FAMILIES else f"**{f}**"
        cells = [f"{agg[m].get(f, float('nan')):.3f}" for m in names]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def summary_table(results: dict[str, list[dict]], params: dict[str, str]) -> str:
    """Markdown table: one row per method, every metric on easy / hard / overall."""
    cols = [f"{m} {g}" for m in METRICS for g in GROUPS]
    lines = ["| method | param | " + " | ".join(cols) + " |",
             "|---|---|" + "---:|" * len(cols)]
    for name, rows in results.items():
        cells = []
        for metric in METRICS:
            agg = aggregate(rows, metric)
            cells += [f"{agg[g]:.3f}" for g in GROUPS]
        lines.append(f"| {name} | {params.get(name, '')} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
