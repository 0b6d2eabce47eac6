"""The synthesis loop: init -> (search, assignment, clustering) x iterations x levels ->
reconstruction, filtering and depth order (seed 000 sec. 6).

Levels go coarse to fine; each level after the first starts from the previous level's
reconstruction, re-sampled at the finer delta. ``SynthesisConfig.clustering`` picks the
clustering step: the paper's greedy one ("greedy", sec. 6.5), the comparison baseline's
spectral clustering ("spectral", sec. 7.2), or none (fixed ids, "none").
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import torch

from cvt.assignment import add_missing, assign_positions
from cvt.clustering import ClusteringParams, ClusteringStats, changed_samples, cluster_step
from cvt.depth import cluster_preferences, order_by_preferences
from cvt.initialization import gaussian_init, patch_init, random_init
from cvt.neighborhood import DistanceParams, distance_batched, neighborhoods, pair_space
from cvt.pair_votes import PairVotes, pair_votes
from cvt.reconstruction import Placement, filter_placements, reconstruct, upsample
from cvt.sampling import DEFAULT_DELTAS, DEFAULT_RADII, Level, Samples, hierarchy, sample_exemplar
from cvt.search import Matches, NearestGrid, SearchParams, patchmatch
from cvt.shape_context import chi2_table, shape_contexts
from cvt.shape_energy import ShapeEnergy
from cvt.spectral import spectral_clusters
from cvt.svg import Exemplar, to_svg
from cvt.torus import Torus, offsets

STEPS = ("init", "search", "assignment", "clustering", "reconstruction")
CLUSTERINGS = ("greedy", "spectral", "none")


@dataclass(frozen=True)
class SynthesisConfig:
    levels: int = 3
    iterations: int = 7
    deltas: tuple[float, ...] = DEFAULT_DELTAS
    radii: tuple[float, ...] = DEFAULT_RADII
    w_f: float = 10.0
    w_a: float = 1.0  # appearance weight, used when the exemplar has appearance attributes
    c_out: float = 4.0
    k_max: int = 24  # neighborhood size cap
    # Input neighborhoods reach a little farther than output ones, so an output sample near
    # the rim can match its true partner just outside r; with equal radii every rim match pulls
    # inwards and the pattern contracts over the iterations.
    in_margin: float = 1.5  # extra input radius, in units of delta
    k_in_extra: int = 8
    init: str = "patch"  # or "random", or "gaussian" (whole elements by their Gaussians)
    first_passes: int = 5  # PatchMatch passes on a level's first iteration (seed 001)
    passes: int = 2
    interior_margin: float = 0.5  # input centers keep this many radii from the border
    huber: float = 1.0  # robust vote weighting in the assignment, in units of delta
    # Shrink or skip assignment steps that would raise seed 000 eq. 4 (monotone energy, ~2x
    # assignment time; off by default: results look the same, see README).
    backtrack: bool = False
    add_samples: bool = True
    # Existence may start a new cluster only with this share of its element's samples at once.
    # Without a clustering step to merge them, fresh one- or two-sample clusters each rebuild a
    # whole element and over-fill the output (0: ~1.3x the expected element count); 1.0 only
    # completes existing clusters, which leaves holes.
    new_cluster_share: float = 0.5
    clustering: str = "greedy"  # "greedy" (sec. 6.5), "spectral" (sec. 7.2), "none"
    cluster: ClusteringParams = ClusteringParams()  # w_l, w_s, lambda, operators
    depth: bool = True  # depth order of the output (sec. 6.4); else input z order
    filter_shapes: bool = True  # drop elements with E'_s(C_o) > |C_o| (sec. 6.6)
    seed: int = 0
    threads: int = 1  # torch threads; more only pays off on an idle machine with big outputs
    # The output canvas is a torus (cvt.torus): neighbourhoods, search, assignment,
    # clustering and depth wrap around, so the result tiles seamlessly.
    tileable: bool = False


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
    level_timings: list[dict[str, float]] = field(default_factory=list)  # per level, per step
    samples_per_level: list[int] = field(default_factory=list)
    clustering: list[tuple[int, int, ClusteringStats]] = field(default_factory=list)


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
    if cfg.clustering not in CLUSTERINGS:
        raise ValueError(f"clustering must be one of {CLUSTERINGS}, got {cfg.clustering!r}")
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
    res.level_timings = [dict.fromkeys(STEPS, 0.0) for _ in levels]
    app = None if exemplar.appearance is None else torch.as_tensor(exemplar.appearance)

    t = time.perf_counter()
    res.inputs = [sample_exemplar(exemplar, lv.delta, seed=cfg.seed + k)
                  for k, lv in enumerate(levels)]
    torus = Torus.of(out_box) if cfg.tileable else None
    if cfg.init == "random":
        out = random_init(res.inputs[0], in_box, out_box, gen)
    elif cfg.init == "gaussian":
        out = gaussian_init(res.inputs[0], in_box, out_box, 2 * levels[0].radius, gen, torus)
    else:
        out = patch_init(res.inputs[0], in_box, out_box, 2 * levels[0].radius, gen, torus)
    _tick(res, 0, "init", t)

    for li, lv in enumerate(levels):
        inp = res.inputs[li]
        out, m, votes = _run_level(li, lv, inp, out, in_box, out_box, cfg, gen, res,
                                   on_iteration, app)
        t = time.perf_counter()
        shape = ShapeEnergy(out.pos, m.center, inp.pos, inp.cluster, lv.delta, torus)
        res.placements = reconstruct(out, inp, m, lv.delta, shape)
        if cfg.filter_shapes:
            res.placements = filter_placements(res.placements)
        res.outputs.append(out)
        res.matches.append(m)
        res.samples_per_level.append(len(out))
        last = li + 1 == len(levels) or not res.placements
        if last and cfg.depth:
            res.placements = depth_order(res.placements, out, m, inp, lv.delta, votes, torus)
        if not last:
            out = upsample(res.placements, res.inputs[li + 1])
        _tick(res, li, "reconstruction", t)
        if last:
            break
    return res


def _tick(res: SynthesisResult, level: int, step: str, start: float) -> None:
    dt = time.perf_counter() - start
    res.timings[step] += dt
    res.level_timings[level][step] += dt


def depth_order(placements: list[Placement], out: Samples, m: Matches, inp: Samples,
                delta: float, votes: PairVotes | None = None,
                torus: Torus | None = None) -> list[Placement]:
    """Placements sorted bottom to top by Order-By-Preferences over f_C (seed 000 eqs. 5-8).

    Clusters without preferences keep their input z order relative to each other.
    """
    if len(placements) < 2:
        return placements
    if votes is None:
        votes = pair_votes(m, out.pos, inp.cluster, inp.z, 2 * delta, torus)
    ids, local = torch.unique(out.cluster, return_inverse=True)
    pref = cluster_preferences(votes, out.pos, local, len(ids), delta, torus)
    row = {int(c): k for k, c in enumerate(ids.tolist())}
    rows = [row[p.cluster] for p in placements]
    sub = pref[np.ix_(rows, rows)]
    key = np.array([(p.z, p.cluster) for p in placements], dtype=float)
    key = np.lexsort((key[:, 1], key[:, 0])).argsort()  # rank in input z order
    return [placements[k] for k in order_by_preferences(sub, key)]


def feature_table(out: Samples, inp: Samples, app: torch.Tensor | None,
                  cfg: SynthesisConfig) -> torch.Tensor:
    """Seed 000 eq. 3's per-sample-pair feature term, before the w_f / 2 of :func:`pair_space`:
    chi2 of shape contexts, plus (w_a / (w_f / 2)) |A(s_o) - A(s_i)|^2 when the exemplar has
    appearance attributes ``app`` (E, D), read through each sample's element (sec. 4.2).
    Shape: -> (N_out, N_in)."""
    table = chi2_table(out.feat, inp.feat)
    if app is None or cfg.w_a <= 0 or cfg.w_f <= 0:
        return table
    a = app.to(table.dtype)
    d2 = torch.cdist(a[out.element.clamp_min(0)], a[inp.element]) ** 2  # (N_out, N_in)
    return table + (cfg.w_a / (0.5 * cfg.w_f)) * d2


def _input_index(inp: Samples, in_box, lv: Level, cfg: SynthesisConfig):
    """Input neighborhoods, allowed centers, their lookup grid and the first search window."""
    in_nbr = neighborhoods(inp.pos, lv.radius + cfg.in_margin * lv.delta,
                           cfg.k_max + cfg.k_in_extra)
    valid = _valid_centers(inp, in_box, cfg.interior_margin * lv.radius)
    grid = NearestGrid(inp.pos, valid, in_box, lv.delta / 3)
    window0 = max(in_box[2] - in_box[0], in_box[3] - in_box[1]) / 2
    return in_nbr, valid, grid, window0


def nearest_neighborhoods(out: Samples, inp: Samples, in_box, lv: Level, cfg: SynthesisConfig,
                          passes: int, gen: torch.Generator) -> Matches:
    """The search step alone, from a random field: each output neighborhood's nearest input
    neighborhood by seed 000 eq. 2 (for evaluating any output, e.g. a baseline's)."""
    in_nbr, valid, grid, window0 = _input_index(inp, in_box, lv, cfg)
    sp = pair_space(out.pos, neighborhoods(out.pos, lv.radius, cfg.k_max), inp.pos, in_nbr,
                    chi2_table(out.feat, inp.feat), DistanceParams(lv.delta, cfg.w_f, cfg.c_out))
    return patchmatch(sp, grid, _start_field(out, valid, gen), SearchParams(passes=passes),
                      window0, gen)


def _run_level(li: int, lv: Level, inp: Samples, out: Samples, in_box, out_box,
               cfg: SynthesisConfig, gen, res: SynthesisResult, on_iteration, app=None):
    t = time.perf_counter()
    torus = Torus.of(out_box) if cfg.tileable else None
    dist = DistanceParams(lv.delta, cfg.w_f, cfg.c_out)
    in_nbr, valid, grid, window0 = _input_index(inp, in_box, lv, cfg)
    table = feature_table(out, inp, app, cfg)  # (N_out, N_in), rows refreshed on cluster changes
    field_ = _start_field(out, valid, gen)
    _tick(res, li, "search", t)
    m = votes = None
    for it in range(cfg.iterations):
        t = time.perf_counter()
        if torus is not None:
            out = out.with_(pos=torus.gather(out.pos, out.cluster))
        out_nbr = neighborhoods(out.pos, lv.radius, cfg.k_max, torus=torus)
        params = SearchParams(passes=cfg.first_passes if it == 0 else cfg.passes)
        sp = pair_space(out.pos, out_nbr, inp.pos, in_nbr, table, dist, torus)
        m = patchmatch(sp, grid, field_, params, window0, gen)
        _tick(res, li, "search", t)
        t = time.perf_counter()
        new_pos = assign_positions(out.pos, m, inp.pos, huber=cfg.huber * lv.delta, torus=torus)
        if cfg.backtrack:
            new_pos = _backtrack(out.pos, new_pos, m, inp, in_nbr, table, dist, lv, cfg, torus)
        out = out.with_(pos=new_pos)
        _tick(res, li, "assignment", t)
        t = time.perf_counter()
        if cfg.clustering != "none":
            votes = pair_votes(m, out.pos, inp.cluster, inp.z,
                               max(cfg.cluster.lam, 2.0) * lv.delta, torus)
            out, table = _cluster(out, m, inp, votes, table, lv, cfg, gen, res, li, it, app,
                                  torus)
        _tick(res, li, "clustering", t)
        t = time.perf_counter()
        field_ = m.center
        if cfg.add_samples and it + 1 < cfg.iterations:
            new = add_missing(out, m, inp, in_nbr, lv.delta, lv.radius, out_box,
                              min_new=cfg.new_cluster_share, torus=torus)
            if len(new):
                out = out.cat(new)
                table = torch.cat([table, feature_table(new, inp, app, cfg)])
                field_ = torch.cat([field_, new.source])
        _tick(res, li, "assignment", t)
        res.energies.append((li, it, m.energy))
        if on_iteration is not None:
            on_iteration(LevelState(li, it, out, m, m.energy))
    if torus is not None:  # the clustering step may have joined samples across the seam
        out = out.with_(pos=torus.gather(out.pos, out.cluster))
    return out, m, votes  # no samples are added after the last search, so m covers all of out


def _cluster(out: Samples, m: Matches, inp: Samples, votes: PairVotes, table, lv: Level,
             cfg: SynthesisConfig, gen, res: SynthesisResult, li: int, it: int, app=None,
             torus: Torus | None = None):
    """One clustering step; shape contexts (and their chi2 rows) of changed clusters are
    recomputed. Returns the new samples and chi2 table."""
    if cfg.clustering == "greedy":
        shape = ShapeEnergy(out.pos, m.center, inp.pos, inp.cluster, lv.delta, torus)
        labels, stats = cluster_step(out.pos, out.cluster, votes, shape, lv.delta, cfg.cluster)
        res.clustering.append((li, it, stats))
    else:  # sec. 7.2 baseline: k = |O| / |I| * |{C_i}| clusters
        near = offsets(out.pos[votes.a] - out.pos[votes.b], torus).norm(dim=1) < (
            cfg.cluster.lam * lv.delta)
        v = votes.select(near)
        k = round(len(out) / len(inp) * len(inp.cluster.unique()))
        seed = int(torch.randint(2**31 - 1, (1,), generator=gen))
        labels = torch.from_numpy(spectral_clusters(v.a.numpy(), v.b.numpy(), v.link.numpy(),
                                                    len(out), max(k, 1), seed))
    changed = changed_samples(out.cluster, labels)
    out = out.with_(cluster=labels)
    if torus is not None:  # a cluster joined across the seam: its samples side by side
        out = out.with_(pos=torus.gather(out.pos, labels))
    if changed.any():
        idx = torch.nonzero(changed).flatten()
        feat = out.feat.clone()
        feat[idx] = shape_contexts(out.pos[idx], labels[idx])
        out = out.with_(feat=feat)
        table = table.clone()
        table[idx] = feature_table(out.select(idx), inp, app, cfg)
    return out, table


def _energy_at(pos, m: Matches, inp: Samples, in_nbr, table, dist, lv: Level, cfg,
               torus=None) -> float:
    """Seed 000 eq. 4 (mean) at positions ``pos`` for the fixed field ``m.center``."""
    sp = pair_space(pos, neighborhoods(pos, lv.radius, cfg.k_max, torus=torus), inp.pos,
                    in_nbr, table, dist, torus)
    d, _ = distance_batched(sp, torch.arange(pos.shape[0]), m.center)
    return float(d.mean())


def _backtrack(old, new, m: Matches, inp, in_nbr, table, dist, lv, cfg,
               torus=None) -> torch.Tensor:
    """Take the least-squares step, or half of it, or none: whichever keeps seed 000 eq. 4 from
    rising.

    Least squares fits squared vote residuals of fixed matchings, not seed 000 eq. 4 itself (robust,
    re-matched, with features), so a full step can raise the energy, mostly at coarse levels.
    """
    for step in (1.0, 0.5):
        pos = old + step * (new - old)
        if _energy_at(pos, m, inp, in_nbr, table, dist, lv, cfg, torus) <= m.energy + 1e-9:
            return pos
    return old


def result_svg(exemplar: Exemplar, res: SynthesisResult) -> str:
    """The synthesized pattern as SVG text: translated copies of input elements."""
    return to_svg(exemplar, [(p.element, p.dx, p.dy) for p in res.placements], res.size)
