"""The texture families, each tagged easy or hard for classical segmentation.

A family is a function ``render(rng, h, w) -> (image (H, W, 3) float32, ids (H, W) int,
params dict)``. The table is written out by hand (no registration side effects).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from neuraltex.data.families import hard, scattered, tiled


@dataclass(frozen=True)
class Family:
    name: str
    hard: bool
    render: Callable
    description: str


def _family(render: Callable, is_hard: bool) -> Family:
    doc = (render.__doc__ or "").strip().removeprefix("HARD: ")
    first = doc.splitlines()[0] if doc else ""
    return Family(render.__name__, is_hard, render, first[:1].upper() + first[1:])


# Ordered from stochastic to regular within each group; the order is part of the
# benchmark definition (families are assigned round-robin), so only append.
FAMILIES: dict[str, Family] = {f.name: f for f in [
    _family(scattered.discs, False),
    _family(scattered.polygons, False),
    _family(scattered.grid, False),
    _family(scattered.dots, False),
    _family(scattered.mixture, False),
    _family(scattered.two_tone, True),
    _family(tiled.stones, False),
    _family(tiled.bricks, False),
    _family(tiled.hex_tiles, False),
    _family(tiled.pebbles, True),
    _family(hard.textured, True),
    _family(hard.soft, True),
    _family(hard.leaves, True),
    _family(hard.scales, True),
    _family(hard.strokes, True),
]}

FAMILY_NAMES: tuple[str, ...] = tuple(FAMILIES)
EASY: tuple[str, ...] = tuple(n for n, f in FAMILIES.items() if not f.hard)
HARD: tuple[str, ...] = tuple(n for n, f in FAMILIES.items() if f.hard)
