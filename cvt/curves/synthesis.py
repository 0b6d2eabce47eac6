"""The curve synthesis loop (seed 001 sec. 4.3): init -> (search, assignment of positions,
edges and existence) x iterations x levels -> paths.

Search and position assignment are cvt's (``neighborhoods``, ``pair_space``, ``patchmatch``,
``assign_positions``) with the curve attributes in the feature table (cvt.curves.similarity);
edges and existence follow eqs. 16-22 (cvt.curves.edges, cvt.curves.existence); stroke ends
the matched neighborhoods do not back are closed after every edge assignment, and broken
fragments dropped after each level's last (cvt.curves.ends). The spacings come from
cvt.curves.spacing (finer for finely detailed strokes). Each level
after the first starts from the previous level's paths re-sampled at the finer spacing. The
domain constraint (eqs. 13, 15) is a predicate ``inside``: samples that a position assignment
moves out of a user's domain shape are pulled back toward its border by eq. 15's domain term
(cvt.curves.domain; ``domain_pull`` 0: dropped, as at the canvas edge, which crops the pattern
like the exemplar's own crop), samples still outside are dropped, and missing samples are only
added inside it. A ``fixed`` graph (autocomplete: what the
user drew) stays where it is, keeps its edges and is never removed; new edges may join it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import torch
from scipy.spatial import cKDTree

from cvt.assignment import assign_positions
from cvt.curves.cleanup import smallest_open
from cvt.curves.domain import Domain, Inside, deep_inside
from cvt.curves.edges import assign_edges, expected_degree
from cvt.curves.ends import (
    CAP_REACH,
    SIDE_BY_SIDE,
    capped_ends,
    close_breaks,
    drop_broken,
    end_evidence,
    near_element,
    paired_share,
    side_by_side,
    unwanted_ends,
)
from cvt.curves.existence import existence, missing_samples
from cvt.curves.graph import CurveGraph, nearest_edges
from cvt.curves.init import box_inside, patch_init
from cvt.curves.reconstruction import trace_paths
from cvt.curves.sampling import exemplar_graph, stroke_graph
from cvt.curves.similarity import edge_embedding, edge_sets, feature_table
from cvt.curves.spacing import curve_levels
from cvt.curves.strokes import CurveExemplar, Stroke
from cvt.neighborhood import DistanceParams, neighborhoods, pair_space
from cvt.sampling import Level
from cvt.search import SearchParams, patchmatch
from cvt.synthesis import _input_index


@dataclass(frozen=True)
class CurveConfig:
    levels: int = 3
    iterations: int = 7
    deltas: tuple[float, ...] = (1 / 18, 1 / 26, 1 / 36)  # sampling distance / exemplar size
    radius: float = 4.0  # neighborhood radius in sampling distances
    k_max: int = 16
    in_margin: float = 1.5  # input neighborhoods reach this many deltas farther (cvt)
    k_in_extra: int = 6
    interior_margin: float = 0.5
    c_out: float = 2.5  # cost of an unmatched output sample, in deltas
    w_edge: float = 0.5  # eq. 5 weight (0 and connectivity=False: the no-connectivity baseline)
    edge_term: str = "embedding"  # eq. 5 as "embedding" or per-pair "matching" (similarity.py)
    w_style: float = 1.0
    connectivity: bool = True  # edge assignment (eqs. 17-22)
    first_passes: int = 5
    passes: int = 2
    huber: float = 1.0
    reach: float = 2.2  # candidate edges join samples closer than this many deltas
    end_reach: float = 4.0  # unwanted stroke ends join within this many deltas (ends.py)
    fragment: int = 6  # broken-off fragments shorter than this many samples go (ends.py)
    # exemplars with this share of their ends facing another end within end_reach (dashed
    # strokes, a sketch's broken lines) keep such output pairs apart (ends.py); > 1: never
    facing_share: float = 0.5
    # exemplars without interior stroke ends (coastlines, rings; fewer than 1 per 100
    # samples): an output end is a defect, so unwanted ends grow (a new sample next to one
    # needs only ``grow`` of the eq. 16 votes; 0.5: off) and join within ``free_reach`` deltas
    grow: float = 0.1
    free_reach: float = 8.0
    init_candidates: int = 16  # patches tried per init cell (init.py)
    # eq. 15 domain term: weight of the pull of a sample outside a user's domain shape toward
    # its border, in votes (a sample has about 2 k_max of weight 1); 0: such samples dropped
    domain_pull: float = 2.0
    detail_turn: float = 1.0  # finer spacings for strokes turning faster (spacing.py; 0: off)
    max_halvings: int = 2
    max_exemplar: int = 1500  # finest exemplar samples the finer spacing may reach
    seed: int = 0
    threads: int = 1

    def level(self, size: float, k: int) -> Level:
        d = self.deltas[len(self.deltas) - self.levels + k] * size
        return Level(d, self.radius * d)


@dataclass
class CurveResult:
    graph: CurveGraph
    size: tuple[float, float]
    delta: float  # finest sampling distance
    inputs: list[CurveGraph] = field(default_factory=list)
    samples_per_level: list[int] = field(default_factory=list)
    energies: list[tuple[int, int, float]] = field(default_factory=list)
    seconds: float = 0.0


@dataclass
class _Level:
    """Everything one level's iterations share."""

    lv: Level
    inp: CurveGraph
    in_emb: object  # the input's edge_embedding, or its edge_sets (edge_term "matching")
    index: tuple  # in_nbr, valid, grid, window0 (cvt.synthesis._input_index)
    inside: Inside
    n_fixed: int
    fixed_edges: torch.Tensor
    capped: np.ndarray  # (N_in,) bool: input ends with a discrete element at them
    deg_in: torch.Tensor  # (N_in,) input degrees, ends cut by the exemplar's canvas as 2
    side: bool  # join unwanted ends side by side (the exemplar has few such ends itself)
    ahead: bool  # join unwanted ends facing each other (the exemplar has few such pairs)
    fragment: int  # broken fragments shorter than this go (ends.drop_broken)
    pull: Domain | None  # a user's domain shape, for eq. 15's pull (None: no shape, or off)

    @property
    def end_free(self) -> bool:
        """The exemplar has (almost) no stroke ends inside its canvas: fewer than 1 per 100
        curve samples (the end statistic's floor, cvt.curves.stats)."""
        curve = self.inp.kind < 0
        return int(((self.deg_in == 1) & curve).sum()) < 0.01 * int(curve.sum())


def synthesize_curves(cx: CurveExemplar, size: tuple[float, float],
                      config: CurveConfig | None = None, inside: Inside | None = None,
                      on_iteration: Callable[[int, int, CurveGraph, float], None] | None = None
                      ) -> CurveResult:
    """Synthesize a ``size`` = (width, height) curve pattern from ``cx`` (exemplar units)."""
    cfg = config or CurveConfig()
    threads = torch.get_num_threads()
    torch.set_num_threads(cfg.threads)
    x0, y0, _, _ = cx.box
    try:
        return run_boxed(cx, (x0, y0, x0 + size[0], y0 + size[1]), cfg, inside, None,
                         on_iteration)
    finally:
        torch.set_num_threads(threads)


def run_boxed(cx: CurveExemplar, out_box, cfg: CurveConfig, inside: Inside | None,
              fixed: Callable[[float], CurveGraph] | None, on_iteration=None,
              levels: list[Level] | None = None) -> CurveResult:
    """The synthesis into ``out_box`` (x0, y0, x1, y1), around the graph ``fixed(delta)``
    (sampled at each level's spacing; its styles index ``cx.styles``); ``levels``: the
    caller's ``curve_levels(cx, cfg)`` if it has them."""
    t0 = time.perf_counter()
    gen = torch.Generator().manual_seed(cfg.seed)
    size = (out_box[2] - out_box[0], out_box[3] - out_box[1])
    domain = box_inside(out_box, inside)
    levels = levels or curve_levels(cx, cfg)
    res = CurveResult(CurveGraph.empty(cx.styles), size, levels[-1].delta)
    res.inputs = [exemplar_graph(cx, lv.delta) for lv in levels]
    out = patch_init(res.inputs[0], cx.box, out_box, 2 * levels[0].radius, domain, gen,
                     cfg.init_candidates)
    for li, lv in enumerate(levels):
        held = fixed(lv.delta) if fixed is not None else None
        out = _drop_near(out, held, lv.delta) if held is not None else out
        pull = Domain.of(domain, out_box, lv.delta / 4) \
            if inside is not None and cfg.domain_pull > 0 else None
        state = _level_state(lv, res.inputs[li], cx, cfg, domain, held, pull)
        out = _run_level(li, state, out, cfg, gen, res, on_iteration)
        res.samples_per_level.append(len(out))
        if li + 1 < len(levels):
            out = carry_sources(out, upsample(out, levels[li + 1].delta), res.inputs[li],
                                res.inputs[li + 1])
    res.graph = out
    res.seconds = time.perf_counter() - t0
    return res


def _level_state(lv, inp, cx, cfg, domain, fixed, pull=None) -> _Level:
    index = _input_index(inp, cx.box, lv, cfg)
    n_fixed = 0 if fixed is None else len(fixed)
    keep = torch.zeros(0, 2, dtype=torch.long) if fixed is None else fixed.edges
    deg = run_on_degree(inp, cx.box, lv.delta)
    side = side_by_side(inp, deg.numpy(), cfg.end_reach / 2 * lv.delta) < SIDE_BY_SIDE
    ahead = paired_share(inp, deg.numpy(), cfg.end_reach * lv.delta, 0.3) < cfg.facing_share
    # no shorter than the exemplar's own shortest open pieces (a sketch's dashes)
    fragment = min(cfg.fragment, smallest_open(inp, cx.box, lv.delta) or cfg.fragment)
    emb = edge_sets(inp, lv.delta) if cfg.edge_term == "matching" else edge_embedding(inp)
    return _Level(lv, inp, emb, index, domain, n_fixed, keep,
                  capped_ends(inp, CAP_REACH * lv.delta), deg, side, ahead, fragment, pull)


def run_on_degree(inp: CurveGraph, box, delta: float) -> torch.Tensor:
    """Input degrees with the stroke ends the exemplar's canvas cut (within 2 ``delta`` of
    ``box``, where the statistics do not count them either) as 2: the stroke runs on there,
    so they back no output end. Shape: -> (N_in,) long."""
    deg = inp.degree().clone()
    cut = torch.from_numpy(_rim(inp.pos, box_inside(box), 2 * delta)) & (deg == 1)
    deg[cut & (inp.kind < 0)] = 2
    return deg


def _drop_near(out: CurveGraph, fixed: CurveGraph, delta: float) -> CurveGraph:
    """The fixed samples first, then the free ones not on top of them."""
    free = out
    if len(fixed) and len(free):
        far = torch.cdist(free.pos, fixed.pos).min(1).values > 0.8 * delta
        free = free.select(torch.nonzero(far).flatten())
    return fixed.cat(free)


def _run_level(li: int, s: _Level, out: CurveGraph, cfg: CurveConfig, gen, res: CurveResult,
               on_iteration) -> CurveGraph:
    in_nbr, valid, grid, window0 = s.index
    rnd = valid[torch.randint(len(valid), (len(out),), generator=gen)]
    field_ = torch.where(out.source >= 0, out.source, rnd)
    for it in range(cfg.iterations):
        if len(out) - s.n_fixed == 0:
            break
        passes = cfg.first_passes if it == 0 else cfg.passes
        m = _search(out, s, cfg, field_, passes, gen)
        out, want = _assign(out, m, s, cfg)
        field_ = m.center
        res.energies.append((li, it, m.energy))
        if it + 1 < cfg.iterations:
            grow = out.pos[unwanted_ends(out, want)] if s.end_free else None
            out, field_ = _existence(out, m, s, field_, grow, cfg.grow)
        else:  # the domain constraint also holds after the last move
            if cfg.connectivity:
                out = drop_broken(out, want, s.fragment, keep=s.n_fixed,
                                  rim=_rim(out.pos, s.inside, 2 * s.lv.delta))
            keep = s.inside(out.pos)
            keep[: s.n_fixed] = True
            out = out.select(torch.nonzero(keep).flatten())
        if on_iteration is not None:
            on_iteration(li, it, out, m.energy)
    return out


def _rim(pos: torch.Tensor, inside: Inside, margin: float) -> np.ndarray:
    """Samples within ``margin`` of the domain border. Shape: (N, 2) -> (N,) bool."""
    return ~deep_inside(pos, inside, margin)


def _search(out: CurveGraph, s: _Level, cfg: CurveConfig, field_, passes: int, gen):
    """PatchMatch over curve neighborhoods (eqs. 7-12; cvt's batched distance)."""
    in_nbr, _, grid, window0 = s.index
    table = feature_table(out, s.inp, cfg.w_edge, cfg.w_style, in_emb=s.in_emb,
                          edge_term=cfg.edge_term, delta=s.lv.delta)
    out_nbr = neighborhoods(out.pos, s.lv.radius, cfg.k_max)
    # w_f = 2: cvt scales the table by w_f / 2, our table already carries its weights
    sp = pair_space(out.pos, out_nbr, s.inp.pos, in_nbr, table,
                    DistanceParams(s.lv.delta, 2.0, cfg.c_out))
    return patchmatch(sp, grid, field_, SearchParams(passes=passes), window0, gen)


def _assign(out: CurveGraph, m, s: _Level, cfg: CurveConfig):
    """Positions by least squares (eqs. 14-15), then edges (eqs. 17-22) with the breaks the
    matched neighborhoods do not back closed (cvt.curves.ends). Returns the graph and the
    expected degrees (eq. 18). Shape: -> CurveGraph, (N,)."""
    pos = _positions(out, m, s, cfg)
    out = out.with_(pos=pos, style=_voted_style(out, m, s), source=m.center)
    center = m.center.numpy()
    bare = s.capped[center] & ~near_element(out, CAP_REACH * s.lv.delta) if s.capped.any() \
        else None
    want = end_evidence(expected_degree(m, out, s.inp, s.deg_in).numpy(),
                        s.deg_in.numpy()[center], bare)
    if not cfg.connectivity:  # the no-connectivity baseline: samples joined to their nearest
        return out.with_(edges=nearest_edges(out, 1.6 * s.lv.delta)), want
    out = out.with_(edges=assign_edges(m, out, s.inp, cfg.reach * s.lv.delta,
                                       keep=s.fixed_edges))
    if not s.end_free:
        return close_breaks(out, want, cfg.end_reach * s.lv.delta, side=s.side,
                            ahead=s.ahead), want
    rim = _rim(out.pos, s.inside, 2 * s.lv.delta)  # the farther joins stay off the border
    return close_breaks(out, want, cfg.free_reach * s.lv.delta, rim=rim, side=s.side,
                        ahead=s.ahead), want


def _positions(out: CurveGraph, m, s: _Level, cfg: CurveConfig) -> torch.Tensor:
    """Eq. 15: least-squares positions; where some free samples land outside the user's
    domain shape, solved again with them pulled toward its border (the domain term), so that
    their strokes bend inside with them instead of being cut. Shape: -> (N, 2)."""
    huber = cfg.huber * s.lv.delta
    pos = assign_positions(out.pos, m, s.inp.pos, huber=huber)
    pos[: s.n_fixed] = out.pos[: s.n_fixed]
    if s.pull is None:
        return pos
    away = ~s.inside(pos)
    away[: s.n_fixed] = False
    idx = torch.nonzero(away).flatten()
    if len(idx) == 0:
        return pos
    target = s.pull.project(pos[idx])
    pos = assign_positions(out.pos, m, s.inp.pos, huber=huber,
                           anchor=(idx, target, cfg.domain_pull))
    pos[: s.n_fixed] = out.pos[: s.n_fixed]
    return pos


def _voted_style(out: CurveGraph, m, s: _Level) -> torch.Tensor:
    """A free sample takes the stroke style of the input sample its neighborhood matched."""
    style = s.inp.style[m.center].clone()
    style[: s.n_fixed] = out.style[: s.n_fixed]
    return torch.where(out.kind < 0, style, out.style)


def _existence(out: CurveGraph, m, s: _Level, field_, grow=None, grow_threshold: float = 0.5):
    """Remove samples with eq. 16 below 1/2 or outside the domain; add missing ones (with
    ``grow_threshold`` of the votes near the unwanted stroke ends ``grow`` (M, 2))."""
    new = missing_samples(out, m, s.inp, s.index[0], s.lv.delta, s.lv.radius, s.inside,
                          grow=grow, grow_threshold=grow_threshold)
    keep = (existence(m, len(out)) >= 0.5) & s.inside(out.pos)
    keep[: s.n_fixed] = True
    idx = torch.nonzero(keep).flatten()
    out, field_ = out.select(idx), field_[idx]
    return out.cat(new), torch.cat([field_, new.source])


def upsample(out: CurveGraph, delta: float) -> CurveGraph:
    """The graph's paths re-sampled at ``delta`` (next level), discrete samples kept."""
    curve = torch.nonzero(out.kind < 0).flatten()
    g = out.select(curve)
    pos = g.pos.numpy()
    strokes = [Stroke(pos[p.nodes], p.closed, p.style) for p in trace_paths(g)]
    new = stroke_graph(strokes, out.styles, delta) if strokes else CurveGraph.empty(out.styles)
    return new.cat(out.select(torch.nonzero(out.kind >= 0).flatten()))


def carry_sources(old: CurveGraph, new: CurveGraph, inp_old: CurveGraph, inp_new: CurveGraph
                  ) -> CurveGraph:
    """The finer level starts from the coarser one's matches, not from random guesses: each
    curve sample of ``new`` takes the input sample of ``inp_new`` nearest to where the source
    (in ``inp_old``) of its nearest curve sample of ``old`` lies, moved by their offset.
    Elements start unmatched (-1, a random guess) as before."""
    src = old.source.numpy()
    ok = (src >= 0) & (old.kind.numpy() < 0)
    ok[ok] = inp_old.kind.numpy()[src[ok]] < 0
    curve_in = np.flatnonzero(inp_new.kind.numpy() < 0)
    mine = np.flatnonzero(new.kind.numpy() < 0)
    if not ok.any() or len(curve_in) == 0 or len(mine) == 0:
        return new
    at = np.flatnonzero(ok)[cKDTree(old.pos.numpy()[ok]).query(new.pos.numpy()[mine])[1]]
    where = inp_old.pos.numpy()[src[at]] + new.pos.numpy()[mine] - old.pos.numpy()[at]
    source = new.source.clone()
    source[mine] = torch.from_numpy(curve_in[cKDTree(inp_new.pos.numpy()[curve_in])
                                             .query(where)[1]])
    return new.with_(source=source)
