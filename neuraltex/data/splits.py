"""Fixed, seeded validation and benchmark splits, disjoint from training seeds.

Training streams must use seeds below ``RESERVED_SEEDS_FROM``; the validation split
(for tuning baselines) and the public benchmark split use their own reserved seeds.
Families are assigned round-robin in ``FAMILY_NAMES`` order, so every family is covered
evenly. The definitions below are the benchmark: do not change them, add new splits.
"""

from __future__ import annotations

from dataclasses import dataclass

from neuraltex.data.families import FAMILY_NAMES
from neuraltex.data.generator import Sample, generate

RESERVED_SEEDS_FROM = 1_000_000
VALIDATION_SEED = 1_000_001
BENCHMARK_SEED = 2_000_003

# (count, size) blocks, in index order.
BENCHMARK_BLOCKS = ((300, 128), (100, 256))
VALIDATION_BLOCKS = ((60, 128), (15, 256))


@dataclass(frozen=True)
class SplitItem:
    seed: int
    index: int
    size: int
    family: str

    def load(self) -> Sample:
        return generate(self.index, self.seed, self.size, family=self.family)


def _split(seed: int, blocks) -> list[SplitItem]:
    items, index = [], 0
    for count, size in blocks:
        for _ in range(count):
            family = FAMILY_NAMES[index % len(FAMILY_NAMES)]
            items.append(SplitItem(seed, index, size, family))
            index += 1
    return items


def benchmark_split() -> list[SplitItem]:
    """The public benchmark: 300 images at 128 px then 100 at 256 px, all families."""
    return _split(BENCHMARK_SEED, BENCHMARK_BLOCKS)


def validation_split() -> list[SplitItem]:
    """The tuning split: 60 images at 128 px then 15 at 256 px, all families."""
    return _split(VALIDATION_SEED, VALIDATION_BLOCKS)


def check_training_seed(seed: int) -> None:
    """Raise if ``seed`` would reuse validation/benchmark samples."""
    from neuraltex.errors import InputError

    if not 0 <= seed < RESERVED_SEEDS_FROM:
        raise InputError(f"training seed must be in [0, {RESERVED_SEEDS_FROM}), got {seed}: "
                         "larger seeds are reserved for the validation and benchmark splits")
