"""Bigger textures from textons: cvt's engine arranges the Gaussians, the decoder paints them.

1. The textons are split into the **background layer** (kind -1, :mod:`neuraltex.texton_kinds`)
   and **elements** (effective textons of kind >= 0); the elements are joined into **groups**,
   the textons of one object (:mod:`neuraltex.texton_groups`): a coin's rim arcs and face,
   whose detail sprites were fitted together, travel together.
2. Each group becomes one Gaussian element of a cvt exemplar (:mod:`cvt.gaussians`: shape =
   the uniform regions of its Gaussians; appearance attributes A(s) = the group's size kind
   (one-hot) and its mean colour in the reconstruction), and cvt's pattern pipeline (seed 000:
   search / assignment, then the canvas and density repair; wrapped around for ``tileable``)
   arranges them on the larger canvas. A picture that repeats a tile
   (:mod:`neuraltex.raster_lattice`) keeps its lattice instead: the output is tiled with its
   cells, each copying the textons centred in a random whole cell of the input
   (:func:`cvt.lattice.cell_copies`, :func:`lattice_arrangement`).
3. The output textons are built **from the input textons by index**: each placement copies the
   textons of its group (every per-texton field travels with them: f, sprites, colour
   offsets, v, existence) and moves mu; the background layer is re-centred and stretched over
   the output canvas (:func:`neuraltex.fit.background_layer`), never placed as an element, its
   detail sprite made constant first (:func:`steady_background`: a stretched sprite would
   paint its centre texels over the whole picture).
4. :func:`decode_arranged` decodes with the texture's (tuned) decoder at the output size; a
   tileable texture is decoded on a canvas padded with the toroidally repeated textons and
   cropped, so the picture wraps around without a seam (G is convolutional and local).
5. With the texture's segment labels, :func:`paste_arranged` then draws each placed element
   from a picture P under its footprint, and fills what the pastes leave uncovered from
   around the nearest paste (:mod:`neuraltex.element_paste`): P is the source picture when
   the caller has it, else the reconstruction R. G's decode stays only as the ground
   beneath, so what arrives is as sharp as P.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import torch
from torch import Tensor

from neuraltex.textons import Textons

WRAP_MARGIN_PX = 32  # padding of the wrap-around decode, pixels (G's reach, 8-aligned)
COVERAGE_PITCH = 64  # pixels per unit of the coverage test (coarse: it compares shares)
TAIL = 5.5  # a Gaussian's opacity is below exp(-30) beyond 5.5 sigma (splatting's _SKIP_M2)


@dataclass(frozen=True)
class ArrangeSettings:
    tileable: bool = False
    seed: int = 0
    iterations: int = 3  # per level
    # One level at delta = exemplar size / 30 (cvt's default is three, 1/20 .. 1/40): a texton
    # is a compact blob of a few samples, and 512 px must take seconds, not minutes.
    deltas: tuple[float, ...] = (1 / 30,)  # sampling distance / exemplar size, per level
    radii: tuple[float, ...] = (1 / 8,)  # neighbourhood radius / exemplar size, per level
    init: str = "patch"  # cvt init: random input patches (seed 000 sec. 6.2); "gaussian"
    #                      (whole textons) left gaps between its cells on textures
    # Cluster ids stay those of the init, whole textons: clustering (seed 000 sec. 6.5)
    # regroups samples into elements, but a texton is one already (and it took 90% of the time).
    method: str = "no-clustering"
    w_a: float = 1.0  # weight of the appearance attributes (kind, colour) in seed 000 eq. 3
    # cvt's density repair, per texton kind: each kind as many per area as in the input (the
    # patch init's cut clusters each rebuild a texton: 1.7x too many on brick without it)
    density: bool = True
    # Largest texton group (neuraltex.texton_groups), share of the input's short side; 0: every
    # texton an element of its own
    group_extent: float = 0.3
    # cvt init of the grouped arrangement: whole groups (a patch init cuts groups at the patch
    # borders, and the pieces, rebuilt as whole groups, crowd the output: coins, patch-SWD 19
    # against 16 one by one and 15.5 with this)
    group_init: str = "gaussian"
    # The two arrangements (groups, alone) run at once in two threads of one torch thread
    # each when the machine has two cores: the same result (each has its own generator), in
    # about the time of the slower one
    parallel: bool = True
    # A picture that repeats a tile (neuraltex.raster_lattice) keeps its lattice: the output is
    # tiled with the input's cells, each from a random whole cell of the input (cvt.lattice)
    lattice: bool = True

    @property
    def steps(self) -> int:  # arranged twice with groups: in groups and one by one
        return len(self.deltas) * self.iterations * (2 if self.group_extent > 0 else 1)


@dataclass
class Arrangement:
    textons: Textons  # (1, K') on the output canvas: background layer first, then elements
    exemplar: object  # the cvt exemplar (cvt.gaussians) the elements were arranged from
    placements: list[tuple[int, float, float]]  # (exemplar row, dx, dy), bottom to top
    rows: Tensor  # (E,) texton index of each exemplar row
    background: Tensor  # (G,) texton indices of the background layer (the first G outputs)
    svg_placements: list[tuple[int, float, float]]  # tileable: with the wrapped-around copies
    background_fill: str  # SVG colour of the background layer
    notes: list[str]
    groups: list[list[int]]  # positions into rows of each exemplar element's textons
    result: object = None  # cvt's SynthesisResult (timings, energies); None on a lattice
    kept: str = "alone"  # how the elements were arranged: "groups", "alone" or "lattice"
    lattice: np.ndarray | None = None  # (2, 2) the input's periods (normalized units), if any
    # (2, 2) whole-pixel (y, x) periods under which the pasted picture repeats exactly, if any
    period: np.ndarray | None = None
    decoded: Tensor | None = None  # (3, H, W) the decode of the arranged textons


def layers(textons: Textons, seed: int = 0,
           channels: int | None = None) -> tuple[Tensor, Tensor, Tensor]:
    """(element indices (E,), their kinds (E,), background indices (G,)) of one texton set:
    elements in draw order (bottom first). ``channels``: how much of f the kinds compare (the
    decoder's feature width: detail sprites left out, :func:`texton_kinds`)."""
    from neuraltex.texton_kinds import texton_kinds

    kinds = texton_kinds(textons, seed=seed, channels=channels)[0].cpu()
    alive = (textons.delta[0] > 0.5).cpu()
    elems = torch.nonzero(alive & (kinds >= 0)).flatten()
    elems = elems[torch.argsort(textons.order[0].cpu()[elems], stable=True)]
    back = torch.nonzero(alive & (kinds < 0)).flatten()
    return elems, kinds[elems], back


def own_size(textons: Textons, short: int) -> tuple[int, int]:
    """(H, W) of the textons' canvas at ``short`` px on its short side: the texture's own size,
    the pixel pitch its decoder is tuned to."""
    w, h = textons.canvas
    return max(1, round(short * h / min(w, h))), max(1, round(short * w / min(w, h)))


def reconstruction(model, textons: Textons, short: int) -> Tensor:
    """The texture decoded at its own size (:func:`own_size`), not clamped. Shape: ->
    (3, H, W)."""
    with torch.no_grad():
        return model.decode(textons, own_size(textons, short))[0]


def texton_colours(model, textons: Textons, short: int,
                   image: Tensor | None = None) -> tuple[Tensor, Tensor]:
    """(colours (K, 3), ground (3,)) in [0, 1]: the mean colour of each texton in the decoded
    texture, weighted by its composited opacity a_i (eq. 4.13), and of what the decoder paints
    where no texton is (weight 1 - sum_i a_i), decoded at the texture's own ``short`` side
    (the decoder is tuned to that pixel pitch; ``image``: that decode (3, H, W), if at hand)."""
    from neuraltex.splatting import splat, weighted_sums

    size = own_size(textons, short)
    with torch.no_grad():
        image = (reconstruction(model, textons, short) if image is None else image)[None]
        ones = textons.f.new_ones(1, textons.num_textons, 1)
        covered = splat(replace(textons, f=ones), size, cutoff=model.cutoff).features[:, :1]
    sums = weighted_sums(textons, torch.cat([image, torch.ones_like(covered)], 1),
                         cutoff=model.cutoff)[0]                       # (K, 4): sum a image, sum a
    colours = sums[:, :3] / sums[:, 3:].clamp_min(1e-6)
    empty = (1 - covered[0, 0]).clamp_min(0)                           # (H, W)
    ground = (image[0] * empty).sum((1, 2)) / empty.sum().clamp_min(1e-6)
    return colours.clamp(0, 1).cpu(), ground.clamp(0, 1).cpu()


def hex_colour(rgb: Tensor) -> str:
    """'#rrggbb' of an RGB colour (3,) in [0, 1]."""
    return "#{:02x}{:02x}{:02x}".format(*(int(round(255 * float(c))) for c in rgb))


def texton_exemplar(textons: Textons, rows: Tensor, groups: list[list[int]], kinds: np.ndarray,
                    colours: Tensor):
    """The cvt exemplar of the element textons ``rows`` (E,) joined into ``groups``
    (cvt.gaussians), with appearance attributes [one-hot group kind, mean colour] (seed 000
    sec. 4.2; the colour weighted by the textons' areas). kinds (len(groups),), colours
    (K, 3)."""
    from cvt.gaussians import gaussian_exemplar
    from neuraltex.texton_kinds import texton_area

    onehot = np.eye(int(kinds.max()) + 1)[kinds]  # (G, kinds)
    rgb = colours[rows].double()  # (E, 3)
    area = texton_area(textons)[0, rows].detach().cpu().double()  # (E,)
    mean = torch.stack([(rgb[g] * area[g, None]).sum(0) / area[g].sum().clamp_min(1e-12)
                        for g in groups])  # (G, 3)
    fills = [hex_colour(col) for col in rgb]
    return gaussian_exemplar(textons.mu[0, rows].detach().cpu().double().numpy(),
                             textons.cov[0, rows].detach().cpu().double().numpy(),
                             np.concatenate([onehot, 2 * mean.numpy()], 1), textons.canvas,
                             fills, groups)


def arrange(textons: Textons, canvas: tuple[float, float], colours: tuple[Tensor, Tensor],
            settings: ArrangeSettings = ArrangeSettings(),
            on_iteration: Callable | None = None, channels: int | None = None,
            lattice: np.ndarray | None = None) -> Arrangement:
    """Arrange one texton set (1, K) on ``canvas`` = (w, h) (normalized units of the input:
    the elements keep their size) with cvt's engine. ``colours``: (per texton (K, 3), ground
    (3,)) (:func:`texton_colours`); ``channels``: see :func:`layers`; ``lattice``: (2, 2)
    rows a, b, the periods of the picture in normalized units (:func:`picture_lattice`), or
    None. With a lattice (and ``settings.lattice``) the cells are tiled
    (:func:`lattice_arrangement`) unless the input holds no whole cell or a tileable canvas is
    no lattice vector; then, and without one, cvt's synthesis arranges.

    With ``settings.group_extent`` the textons are arranged both in groups and one by one, and
    the arrangement whose elements cover the canvas in the share closest to the input's is
    kept (:func:`coverage`): groups keep objects whole (coins, bricks, bark ridges), but
    groups cut from a texture of touching pieces (a leopard's spots) leave holes between them.
    """
    from neuraltex.errors import InputError

    elems, _, back = layers(textons, settings.seed, channels)
    if len(elems) < 2:
        raise InputError(f"the texture has {len(elems)} element texton(s) besides its "
                         "background: nothing to arrange")
    notes = []
    if lattice is not None and settings.lattice:
        arr = lattice_arrangement(textons, elems, back, canvas, colours, settings, lattice)
        if arr is not None:
            arr.lattice = lattice
            return arr
        notes.append(f"lattice {_periods_text(lattice)}: "
                     + ("the tileable canvas is not a whole number of cells" if settings.tileable
                        else "no whole cell in the input") + "; arranged by cvt instead")
    if on_iteration is not None:  # the arrangements may report from two threads
        on_iteration = _serialized(on_iteration)
    alone = replace(settings, group_extent=0.0)
    grouped = replace(settings, init=settings.group_init)
    tries = side_by_side(
        [partial(_arrange, textons, elems, back, canvas, colours, s, on_iteration)
         for s in ((grouped, alone) if settings.group_extent > 0 else (alone,))],
        settings.parallel)
    for arr in tries:
        arr.notes[:0] = notes
        arr.lattice = lattice if settings.lattice else None
    if len(tries) == 1:
        return tries[0]
    target = coverage(textons.index(torch.cat([back, elems])), len(back))
    share = [coverage(arr.textons, len(back)) for arr in tries]
    best = int(np.argmin([abs(c - target) for c in share]))
    tries[best].notes.append(f"coverage: input {target:.3f}, groups {share[0]:.3f}, textons "
                             f"alone {share[1]:.3f}: {('groups', 'textons alone')[best]} kept")
    return tries[best]


def picture_lattice(picture: Tensor, short: int) -> np.ndarray | None:
    """The lattice of a picture (3, H, W) in [0, 1] (:mod:`neuraltex.raster_lattice`), in
    normalized units at ``short`` pixels per unit, rows a, b; None when it does not repeat.
    Shape: -> (2, 2)."""
    from neuraltex.raster_lattice import raster_lattice

    basis = raster_lattice(picture.detach().clamp(0, 1).permute(1, 2, 0).cpu().numpy())
    return None if basis is None else basis / short


def _periods_text(basis: np.ndarray) -> str:
    return " and ".join(f"({a[0]:.4g}, {a[1]:.4g})" for a in basis)


def lattice_arrangement(textons: Textons, elems: Tensor, back: Tensor,
                        canvas: tuple[float, float], colours: tuple[Tensor, Tensor],
                        settings: ArrangeSettings, basis: np.ndarray) -> Arrangement | None:
    """The element textons ``elems`` (E,), one by one, on the cells of the lattice ``basis``
    (2, 2) tiled over ``canvas`` (:func:`cvt.lattice.cell_copies`: each output cell copies the
    textons centred in a random whole cell of the input, seeded), over the background textons
    ``back``; None when the input holds no whole cell, or a tileable canvas is not a lattice
    vector along both axes."""
    from cvt.lattice import cell_copies, torus_cells
    from neuraltex.texton_groups import group_kinds

    if settings.tileable and torus_cells(basis, canvas) is None:
        return None
    colours, ground = colours
    groups = [[i] for i in range(len(elems))]
    ex = texton_exemplar(textons, elems, groups, group_kinds(textons, elems, groups), colours)
    boxes = np.stack([e.bbox for e in ex.elements])  # (E, 4)
    centers = textons.mu[0, elems].detach().cpu().double().numpy()  # (E, 2)
    w, h = textons.canvas
    copies = cell_copies(basis, centers, boxes, (0.0, 0.0, w, h), (0.0, 0.0, *canvas),
                         np.random.default_rng(settings.seed),
                         canvas if settings.tileable else None)
    if copies is None:
        return None
    placed = copies
    if settings.tileable:  # one copy each (centre on the canvas); the decode wraps around
        placed = [p for p in copies if _centred(boxes[p[0]], p, canvas)]
    out = place(textons, elems, placed, back, canvas)
    fill = hex_colour(colours[back[0]] if len(back) else ground)
    note = (f"lattice {_periods_text(basis)}: the input's cells tiled, each from a random "
            "whole cell of the input")
    return Arrangement(out, ex, placed, elems, back, copies, fill, [note], groups,
                       kept="lattice")


def _serialized(fn: Callable) -> Callable:
    """``fn`` behind a lock: one call at a time, from any thread."""
    lock = threading.Lock()

    def call(*args, **kwargs):
        with lock:
            return fn(*args, **kwargs)

    return call


def side_by_side(jobs: list[Callable], parallel: bool = True) -> list:
    """The results of ``jobs`` (calls without arguments), in order: with ``parallel`` and two
    or more usable cores, each in a thread of its own with one torch thread (torch releases
    the GIL in its kernels; the thread count is process-wide, so it is set once around all of
    them, and results equal the sequential ones); the caller's grad mode (thread-local)
    carries over."""
    from neuraltex.cores import usable_cores

    if not parallel or len(jobs) < 2 or usable_cores() < 2:
        return [job() for job in jobs]
    grad, threads = torch.is_grad_enabled(), torch.get_num_threads()

    def run(job: Callable):
        with torch.set_grad_enabled(grad):
            return job()

    torch.set_num_threads(1)
    try:
        with ThreadPoolExecutor(len(jobs)) as pool:
            futures = [pool.submit(run, job) for job in jobs]
            return [f.result() for f in futures]
    finally:
        torch.set_num_threads(threads)


def _arrange(textons: Textons, elems: Tensor, back: Tensor, canvas: tuple[float, float],
             colours: tuple[Tensor, Tensor], settings: ArrangeSettings,
             on_iteration: Callable | None) -> Arrangement:
    """:func:`arrange` with the element textons ``elems`` (E,) joined into groups of at most
    ``settings.group_extent`` (one each at 0), over the background textons ``back``."""
    from cvt.pattern import PatternOptions, synthesize_pattern
    from cvt.synthesis import SynthesisConfig
    from neuraltex.texton_groups import group_kinds, texton_groups

    colours, ground = colours
    groups = texton_groups(textons, elems, extent=settings.group_extent)
    kinds = group_kinds(textons, elems, groups)
    ex = texton_exemplar(textons, elems, groups, kinds, colours)
    cfg = SynthesisConfig(levels=len(settings.deltas), iterations=settings.iterations,
                          deltas=settings.deltas, radii=settings.radii, seed=settings.seed,
                          init=settings.init, w_a=settings.w_a)
    opts = PatternOptions(lattice=False, density=settings.density, tileable=settings.tileable,
                          kinds=kinds)
    pattern = synthesize_pattern(ex, canvas, cfg, settings.method, opts, on_iteration)
    placed = pattern.placements
    if settings.tileable:  # one copy each (centre on the canvas); the decode wraps around
        placed = [p for p in placed if _centred(ex.elements[p[0]].bbox, p, canvas)]
    out = place(textons, elems, [(e, dx, dy) for g, dx, dy in placed for e in groups[g]],
                back, canvas)
    fill = hex_colour(colours[back[0]] if len(back) else ground)
    return Arrangement(out, ex, placed, elems, back, pattern.placements, fill,
                       list(pattern.notes), groups, pattern.result,
                       kept="groups" if settings.group_extent > 0 else "alone")


def coverage(textons: Textons, skip: int = 0, pitch: int = COVERAGE_PITCH) -> float:
    """Mean share of the canvas the textons after the first ``skip`` (the background layer)
    cover: 1 - prod_i (1 - o_i) = sum_i a_i (eq. 4.13's composited weights), at ``pitch``
    pixels per unit."""
    from neuraltex.splatting import splat

    w, h = textons.canvas
    elems = textons.index(torch.arange(skip, textons.num_textons))
    ones = elems.f.new_ones(1, elems.num_textons, 1)
    with torch.no_grad():
        a = splat(replace(elems, f=ones), (max(1, round(pitch * h)), max(1, round(pitch * w))))
    return float(a.features[0, 0].clamp(0, 1).mean())


def _centred(box: np.ndarray, p: tuple[int, float, float], canvas) -> bool:
    cx, cy = (box[0] + box[2]) / 2 + p[1], (box[1] + box[3]) / 2 + p[2]
    return 0 <= cx < canvas[0] and 0 <= cy < canvas[1]


def place(textons: Textons, rows: Tensor, placed: list[tuple[int, float, float]],
          back: Tensor, canvas: tuple[float, float]) -> Textons:
    """Output textons: texton ``rows[e]`` moved by (dx, dy) for each placement (e, dx, dy), in
    the input's draw order (ties: placement order), over the background textons ``back``
    stretched to ``canvas`` (:func:`neuraltex.fit.background_layer`)."""
    from neuraltex.fit import background_layer

    src = rows[torch.tensor([p[0] for p in placed], dtype=torch.long)]  # (P,)
    shift = torch.tensor([[p[1], p[2]] for p in placed], dtype=textons.dtype).reshape(-1, 2)
    elems = textons.index(src.to(textons.device))
    rank = torch.from_numpy(np.lexsort((np.arange(len(src)), textons.order[0, src].cpu())))
    order = torch.empty_like(rank)
    order[rank] = torch.arange(len(rank))
    elems = replace(elems, mu=elems.mu + shift.to(elems.device)[None],
                    order=order[None].to(textons.device), canvas=canvas)
    if not len(back):
        return elems
    bg = replace(textons.index(back.to(textons.device)), canvas=canvas)
    for k in range(len(back)):
        bg = background_layer(bg, k)
    return Textons.cat([bg, elems])


def periodic(textons: Textons, margin: float, elements_from: int = 0) -> Textons:
    """The textons and their copies shifted by whole canvases that reach into a ``margin``
    (normalized units) around the canvas: the torus unrolled. Textons before
    ``elements_from`` (the background layer) are not repeated."""
    w, h = textons.canvas
    sigma = torch.linalg.eigvalsh(textons.cov[0])[:, 1].clamp_min(0).sqrt()  # (K,) major axis
    reach = TAIL * sigma + margin  # (K,)
    x, y = textons.mu[0, :, 0], textons.mu[0, :, 1]
    copies = [textons]
    for i in (-1, 0, 1):
        for j in (-1, 0, 1):
            if not (i or j):
                continue
            nx, ny = x + i * w, y + j * h
            near = ((nx > -reach) & (nx < w + reach) & (ny > -reach) & (ny < h + reach))
            near[:elements_from] = False
            idx = torch.nonzero(near).flatten()
            if len(idx):
                copies.append(textons.index(idx).translate(i * w, j * h))
    return Textons.cat(copies, on_top=False)


def decode_arranged(model, textons: Textons, size: tuple[int, int], tileable: bool = False,
                    background: int = 0) -> Tensor:
    """Decode an arrangement at ``size`` = (H, W) over its whole canvas; ``tileable``:
    on the padded torus, cropped, so that the picture wraps around. ``background``: how many
    leading textons are the background layer. Shape: -> (3, H, W) in [0, 1]."""
    H, W = size
    w, h = textons.canvas
    pad = WRAP_MARGIN_PX if tileable else 0
    m = pad * w / W  # margin in normalized units
    if tileable:
        textons = periodic(textons, m, background)
    window = (-m, -m, w + m, h + m)  # square pixels: the canvas has the aspect of size
    with torch.no_grad():
        out = model.decode(textons, (H + 2 * pad, W + 2 * pad), window=window)
    return out[0, :, pad:pad + H, pad:pad + W].clamp(0, 1)


def steady_background(textons: Textons, background: Tensor, plain: int, short: int,
                      cutoff: float | None = None) -> Textons:
    """The textons with the detail sprites of the ``background`` textons made constant: each
    the mean its sprite adds where that texton shows in the texture (decoded at its own
    ``short`` side), r(p) / share(p) averaged with weight share(p)
    (:mod:`neuraltex.texton_detail`). ``plain``: f's channels before the sprites."""
    from neuraltex.texton_detail import DetailSampler, attach, split

    plain_textons, sprites = split(textons, plain)
    if sprites is None or not len(background):
        return textons
    size = own_size(textons, short)
    sampler = DetailSampler(plain_textons, size, cutoff=cutoff)
    sprites = sprites.clone()
    with torch.no_grad():
        for b in background.tolist():
            only = torch.zeros_like(sprites)
            only[:, b] = sprites[:, b]
            share = sampler.render(torch.zeros_like(sprites).index_fill_(1, torch.tensor([b]),
                                                                          1.0))[:, :1]
            detail = sampler.render(only)  # (B, 3, H, W)
            mean = detail.sum((-1, -2)) / share.sum((-1, -2)).clamp_min(1e-6)  # (B, 3)
            sprites[:, b] = mean[..., None, None]
    return attach(plain_textons, sprites)


def paste_arranged(textons: Textons, rows: Tensor, groups: list[list[int]],
                   placements: list[tuple[int, float, float]], pixels: Tensor,
                   labels: np.ndarray, short: int, ground: Tensor,
                   tileable: bool = False, period: np.ndarray | None = None) -> Tensor:
    """``ground`` (3, H, W) with every placement (element, dx, dy) of the elements ``groups``
    (positions into ``rows`` (E,), texton indices of the input ``textons``) drawn from
    ``pixels`` (3, h, w: the reconstruction, or the source picture at its size) under its
    footprint in ``labels`` (h, w: texton of each pixel) (:mod:`neuraltex.element_paste`),
    bottom to top in the input's draw order. ``period``: :func:`exact_period` of ``pixels``.
    -> (3, H, W) in [0, 1]."""
    from neuraltex.element_paste import (
        cutouts,
        element_rank,
        fill_gaps,
        paste,
        pixel_placements,
    )

    rows, pixels = rows.cpu().numpy(), pixels.clamp(0, 1).cpu()
    pieces = cutouts(pixels, labels, rows, groups, textons.num_textons)
    rank = element_rank(textons.order[0].cpu().numpy(), rows, groups)
    placed = pixel_placements(placements, rank, short)
    pasted = paste(ground.cpu(), pieces, placed, tileable)
    return fill_gaps(pasted, pixels, ground.cpu(), tileable,
                     period=period).clamp(0, 1).to(ground)


def synthesize_texture(decoder, textons: Textons, short: int, size: tuple[int, int],
                       settings: ArrangeSettings = ArrangeSettings(),
                       on_iteration: Callable | None = None,
                       labels: np.ndarray | None = None,
                       source: Tensor | None = None) -> tuple[Tensor, Arrangement]:
    """(picture (3, H, W), arrangement) of a texture grown to ``size`` = (H, W) at the
    input's pixel pitch (``short`` px per normalized unit): arrange, then decode; with the
    texture's ``labels`` (h, w; texton of each pixel, a texture file's segments) each placed
    element then brings the pixels of ``source`` (3, h', w'), the picture the textons were
    fitted to, under its footprint, or the reconstruction's when there is no source
    (:func:`paste_arranged`; the decode stays as the ground between them, and in
    ``arr.decoded``)."""
    plain = decoder.generator.feature_channels - 2
    recon = reconstruction(decoder, textons, short)
    colours = texton_colours(decoder, textons, short, recon)
    steady = steady_background(textons, layers(textons, settings.seed, plain)[2], plain, short,
                               decoder.cutoff)
    canvas = (size[1] / short, size[0] / short)
    pixels = recon if source is None else source_pixels(source, recon.shape[-2:])
    lattice = picture_lattice(pixels, short) if settings.lattice else None
    arr = arrange(steady, canvas, colours, settings, on_iteration, plain, lattice)
    image = decode_arranged(decoder, arr.textons, size, settings.tileable, len(arr.background))
    arr.decoded = image
    arr.period = None if lattice is None else exact_period(pixels, lattice, short)
    if labels is not None:
        image = paste_arranged(textons, arr.rows, arr.groups, arr.placements, pixels, labels,
                               short, image, settings.tileable, arr.period)
    return image, arr


def exact_period(picture: Tensor, lattice: np.ndarray, short: int) -> np.ndarray | None:
    """The ``lattice`` (2, 2) rows, normalized units) in whole pixels of ``picture`` (3, H, W)
    at ``short`` px per unit, rows (y, x), when the picture repeats exactly under it
    (:func:`neuraltex.raster_lattice.repeats_exactly`: a tile repeated to the pixel, whose
    copies meet without a join); else None. Shape: -> (2, 2)."""
    from neuraltex.raster_lattice import repeats_exactly

    basis = lattice * short  # (x, y) rows, pixels
    hwc = picture.detach().permute(1, 2, 0).cpu().numpy()
    return np.round(basis[:, ::-1]).astype(int) if repeats_exactly(hwc, basis) else None


def source_pixels(source: Tensor, size: tuple[int, int]) -> Tensor:
    """The source picture (3, h, w) at the reconstruction's ``size`` = (H, W), resampled as
    ``neuraltex fit`` resampled it (:func:`neuraltex.nn_utils.resize`), in [0, 1].
    -> (3, H, W)."""
    from neuraltex.nn_utils import resize

    return resize(source[None].float(), tuple(size))[0].clamp(0, 1)
