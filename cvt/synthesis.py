"""The synthesis loop: init -> (search, assignment) x iterations x levels -> reconstruction.

Seed 000 sec. 6 without the clustering step (issue 8). Levels go coarse to fine; each level
after the first starts from the previous level's reconstruction, re-sampled at the finer delta.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import torch

from cvt.assignment import add_missing, assign_positions
from cvt.initialization import patch_init, random_init
from cvt.neighborhood import DistanceParams, distance_batched, neighborhoods, pair_space
from cvt.reconstruction import Placement, merge_duplicates, reconstruct, upsample
from cvt.sampling import DEFAULT_DELTAS, DEFAULT_RADII, Level, Samples, hierarchy, sample_exemplar
from cvt.search import Matches, NearestGrid, SearchParams, patchmatch
from cvt.shape_context import chi2_table
from cvt.svg import Exemplar, to_svg

STEPS = ("init", "search", "assignment", "reconstruction")


@dataclass(frozen=True)
class SynthesisConfig:
    levels: int = 3
    iterations: int = 7
    deltas: tuple[float, ...] = DEFAULT_DELTAS
    radii: tuple[float, ...] = DEFAULT_RADII
    w_f: float = 10.0
    c_out: float = 4.0
    k_max: int = 24  # neighborhood size cap
    # Input neighborhoods reach a little farther than output ones, so an output sample near
    # the rim can match its true partner just outside r; with equal radii every rim match pulls
    # inwards and the pattern contracts over the iterations.
    in_margin: float = 1.5  # extra input radius, in units of delta
    k_in_extra: int = 8
    init: str = "patch"  # or "random"
    first_passes: int = 5  # PatchMatch passes on a level's first iteration (seed 001)
    passes: int = 2
    interior_margin: float = 0.5  # input centers keep this many radii from the border
    huber: float = 1.0  # robust vote weighting in the assignment, in units of delta
    # Shrink or skip assignment steps that would raise eq. 4 (monotone energy, ~2x assignment
    # time; off by default: results look the same, see README).
    backtrack: bool = False
    add_samples: bool = True
    # Existence may start a new cluster only with this share of its element's samples at once.
    # Without the clustering step (issue 8) to merge them, fresh one- or two-sample clusters
    # each rebuild a whole element and over-fill the output (0: ~1.3x the expected element
    # count); 1.0 only completes existing clusters, which leaves holes.
    new_cluster_share: float = 0.5
    merge_duplicates: bool = True  # v0 stopgap until the clustering step (issue 8)
    seed: int = 0
    threads: int = 1  # torch threads; more only pays off on an idle machine with big outputs


@dataclass
class LevelState:
    """What one iteration leaves behind: samples and the matches that moved them."""

    level: int
    iteration: int
    samples: Samples
    matches: Matches
    energy: float


@dataclass
class SynthesisResult:
    placements: list[Placement]
    size: tuple[float, float]
    inputs: list[Samples]
    outputs: list[Samples]  # final samples per level
    matches: list[Matches] = field(default_factory=list)  # last search of each level
    energies: list[tuple[int, int, float]] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=lambda: dict.fromkeys(STEPS, 0.0))
    samples_per_level: list[int] = field(default_factory=list)


def _valid_centers(inp: Samples, box, margin: float) -> torch.Tensor:
    x0, y0, x1, y1 = box
    for m in (margin, margin / 2, 0.0):
        ok = ((inp.pos[:, 0] >= x0 + m) & (inp.pos[:, 0] <= x1 - m)
              & (inp.pos[:, 1] >= y0 + m) & (inp.pos[:, 1] <= y1 - m))
        if ok.sum() >= 8:
            break
    return torch.nonzero(ok).flatten()


def _start_field(out: Samples, valid: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
    """Random field (seed 001), except samples that know their source input sample."""
    rnd = valid[torch.randint(len(valid), (len(out),), generator=gen)]
    return torch.where(out.source >= 0, out.source, rnd)


def synthesize(exemplar: Exemplar, size: tuple[float, float], config: SynthesisConfig | None = None,
               on_iteration: Callable[[LevelState], None] | None = None) -> SynthesisResult:
    """Synthesize a ``size`` = (width, height) pattern (exemplar user units) from ``exemplar``."""
    cfg = config or SynthesisConfig()
    threads = torch.get_num_threads()
    torch.set_num_threads(cfg.threads)
    try:
        return _synthesize(exemplar, size, cfg, on_iteration)
    finally:
        torch.set_num_threads(threads)


def _synthesize(exemplar: Exemplar, size, cfg: SynthesisConfig, on_iteration) -> SynthesisResult:
    gen = torch.Generator().manual_seed(cfg.seed)
    levels = hierarchy(exemplar.size, cfg.levels, cfg.deltas, cfg.radii)
    vx, vy, vw, vh = exemplar.viewbox
    in_box = (vx, vy, vx + vw, vy + vh)
    out_box = (vx, vy, vx + size[0], vy + size[1])
    res = SynthesisResult([], size, [], [])
    boxes = np.stack([e.bbox for e in exemplar.elements])  # (E, 4)

    t = time.perf_counter()
    res.inputs = [sample_exemplar(exemplar, lv.delta, seed=cfg.seed + k)
                  for k, lv in enumerate(levels)]
    if cfg.init == "random":
        out = random_init(res.inputs[0], in_box, out_box, gen)
    else:
        out = patch_init(res.inputs[0], in_box, out_box, 2 * levels[0].radius, gen)
    res.timings["init"] += time.perf_counter() - t

    for li, lv in enumerate(levels):
        inp = res.inputs[li]
        out, m = _run_level(li, lv, inp, out, in_box, out_box, cfg, gen, res, on_iteration)
        t = time.perf_counter()
        res.placements = reconstruct(out, inp, m, lv.delta)
        if cfg.merge_duplicates:
            res.placements = merge_duplicates(res.placements, boxes)
        res.outputs.append(out)
        res.matches.append(m)
        res.samples_per_level.append(len(out))
        if li + 1 < len(levels) and res.placements:
            out = upsample(res.placements, res.inputs[li + 1])
        elif li + 1 < len(levels):
            break  # nothing left to refine
        res.timings["reconstruction"] += time.perf_counter() - t
    return res


def _run_level(li: int, lv: Level, inp: Samples, out: Samples, in_box, out_box,
               cfg: SynthesisConfig, gen, res: SynthesisResult, on_iteration):
    t = time.perf_counter()
    dist = DistanceParams(lv.delta, cfg.w_f, cfg.c_out)
    in_nbr = neighborhoods(inp.pos, lv.radius + cfg.in_margin * lv.delta,
                           cfg.k_max + cfg.k_in_extra)
    valid = _valid_centers(inp, in_box, cfg.interior_margin * lv.radius)
    grid = NearestGrid(inp.pos, valid, in_box, lv.delta / 3)
    table = chi2_table(out.feat, inp.feat)  # (N_out, N_in), features fixed within a level
    field_ = _start_field(out, valid, gen)
    window0 = max(in_box[2] - in_box[0], in_box[3] - in_box[1]) / 2
    res.timings["search"] += time.perf_counter() - t
    m = None
    for it in range(cfg.iterations):
        t = time.perf_counter()
        out_nbr = neighborhoods(out.pos, lv.radius, cfg.k_max)
        params = SearchParams(passes=cfg.first_passes if it == 0 else cfg.passes)
        sp = pair_space(out.pos, out_nbr, inp.pos, in_nbr, table, dist)
        m = patchmatch(sp, grid, field_, params, window0, gen)
        res.timings["search"] += time.perf_counter() - t
        t = time.perf_counter()
        new_pos = assign_positions(out.pos, m, inp.pos, huber=cfg.huber * lv.delta)
        if cfg.backtrack:
            new_pos = _backtrack(out.pos, new_pos, m, inp, in_nbr, table, dist, lv, cfg)
        out = out.with_(pos=new_pos)
        field_ = m.center
        if cfg.add_samples and it + 1 < cfg.iterations:
            new = add_missing(out, m, inp, in_nbr, lv.delta, lv.radius, out_box,
                              min_new=cfg.new_cluster_share)
            if len(new):
                out = out.cat(new)
                table = torch.cat([table, chi2_table(new.feat, inp.feat)])
                field_ = torch.cat([field_, new.source])
        res.timings["assignment"] += time.perf_counter() - t
        res.energies.append((li, it, m.energy))
        if on_iteration is not None:
            on_iteration(LevelState(li, it, out, m, m.energy))
    return out, m  # no samples are added after the last search, so m covers all of out


def _energy_at(pos, m: Matches, inp: Samples, in_nbr, table, dist, lv: Level, cfg) -> float:
    """Eq. 4 (mean) at positions ``pos`` for the fixed field ``m.center``."""
    sp = pair_space(pos, neighborhoods(pos, lv.radius, cfg.k_max), inp.pos, in_nbr, table, dist)
    d, _ = distance_batched(sp, torch.arange(pos.shape[0]), m.center)
    return float(d.mean())


def _backtrack(old, new, m: Matches, inp, in_nbr, table, dist, lv, cfg) -> torch.Tensor:
    """Take the least-squares step, or half of it, or none: whichever keeps eq. 4 from rising.

    Least squares fits squared vote residuals of fixed matchings, not eq. 4 itself (robust,
    re-matched, with features), so a full step can raise the energy, mostly at coarse levels.
    """
    for step in (1.0, 0.5):
        pos = old + step * (new - old)
        if _energy_at(pos, m, inp, in_nbr, table, dist, lv, cfg) <= m.energy + 1e-9:
            return pos
    return old


def result_svg(exemplar: Exemplar, res: SynthesisResult) -> str:
    """The synthesized pattern as SVG text: translated copies of input elements."""
    return to_svg(exemplar, [(p.element, p.dx, p.dy) for p in res.placements], res.size)
