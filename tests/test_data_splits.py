from collections import Counter

import pytest

from neuraltex.baselines import METHODS, Method, grid_segmenter
from neuraltex.data.families import FAMILY_NAMES
from neuraltex.data.splits import (
    RESERVED_SEEDS_FROM,
    benchmark_split,
    check_training_seed,
    validation_split,
)
from neuraltex.errors import InputError
from neuraltex.evaluation import aggregate, family_table, score, tune


def test_splits_are_fixed_balanced_and_disjoint():
    bench, val = benchmark_split(), validation_split()
    assert len(bench) == 400 and len(val) == 75
    assert Counter(it.size for it in bench) == {128: 300, 256: 100}
    counts = Counter(it.family for it in bench)
    assert set(counts) == set(FAMILY_NAMES) and max(counts.values()) - min(counts.values()) <= 1
    seeds = {it.seed for it in bench} | {it.seed for it in val}
    assert len(seeds) == 2 and min(seeds) >= RESERVED_SEEDS_FROM
    assert bench == benchmark_split()  # deterministic


def test_training_seed_check():
    check_training_seed(0)
    with pytest.raises(InputError):
        check_training_seed(RESERVED_SEEDS_FROM)
    with pytest.raises(InputError):
        check_training_seed(-1)


def test_score_aggregate_and_tune():
    samples = [it.load() for it in validation_split()[:4]]  # 4 families, 128 px
    rows = score(grid_segmenter(6), samples, progress=False)
    assert [r["family"] for r in rows] == list(FAMILY_NAMES[:4])
    agg = aggregate(rows)
    assert set(agg) == set(FAMILY_NAMES[:4]) | {"easy", "hard", "overall"}
    assert agg["overall"] == pytest.approx(sum(r["miou"] for r in rows) / 4)
    m = Method("grid", grid_segmenter, "cells", 6, (2, 8))
    best, curve = tune(m, samples, progress=False)
    assert set(curve) == {2, 8} and best == max(curve, key=curve.get)
    assert curve[8] > curve[2]  # 2x2 cells cannot match ~30 textons
    assert "| discs (easy) |" in family_table({"grid": rows})
    assert set(METHODS) == {"grid", "slic", "felzenszwalb", "kmeans"}
