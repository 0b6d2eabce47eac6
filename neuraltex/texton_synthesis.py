"""Bigger textures from textons: cvt's engine arranges the Gaussians, the decoder paints them.

1. The textons are split into the **background layer** (kind -1, :mod:`neuraltex.texton_kinds`)
   and **elements** (effective textons of kind >= 0).
2. The elements become Gaussian elements of a cvt exemplar (:mod:`cvt.gaussians`: shape = the
   Gaussian's uniform region, bottom to top in draw order; appearance attributes A(s) = the
   texton's kind (one-hot) and its colour in the reconstruction), and cvt's pattern pipeline
   (seed 000: search / assignment / clustering, then the canvas and density repair; wrapped
   around for ``tileable``) arranges them on the larger canvas.
3. The output textons are built **from the input textons by index**: each placement copies its
   texton (every per-texton field travels with it: f, colour offsets, v, existence) and moves
   mu; the background layer is re-centred and stretched over the output canvas
   (:func:`neuraltex.fit.background_layer`), never placed as an element.
4. :func:`decode_arranged` decodes with the texture's (tuned) decoder at the output size; a
   tileable texture is decoded on a canvas padded with the toroidally repeated textons and
   cropped, so the picture wraps around without a seam (G is convolutional and local).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import torch
from torch import Tensor

from neuraltex.textons import Textons

WRAP_MARGIN_PX = 32  # padding of the wrap-around decode, pixels (G's reach, 8-aligned)
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

    @property
    def steps(self) -> int:
        return len(self.deltas) * self.iterations


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
    result: object = None  # cvt's SynthesisResult (timings, energies)


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


def texton_colours(model, textons: Textons, short: int) -> tuple[Tensor, Tensor]:
    """(colours (K, 3), ground (3,)) in [0, 1]: the mean colour of each texton in the decoded
    texture, weighted by its composited opacity a_i (eq. 4.13), and of what the decoder paints
    where no texton is (weight 1 - sum_i a_i), decoded at the texture's own ``short`` side
    (the decoder is tuned to that pixel pitch)."""
    from neuraltex.splatting import opacity_maps

    w, h = textons.canvas
    size = (max(1, round(short * h / min(w, h))), max(1, round(short * w / min(w, h))))
    with torch.no_grad():
        image = model.decode(textons, size)[0].flatten(1)  # (3, HW)
        a = opacity_maps(textons, size, cutoff=model.cutoff)[0].flatten(1)  # (K, HW)
    colours = (a @ image.T) / a.sum(1, keepdim=True).clamp_min(1e-6)  # (K, 3)
    empty = (1 - a.sum(0)).clamp_min(0)  # (HW,)
    ground = (image @ empty) / empty.sum().clamp_min(1e-6)  # (3,)
    return colours.clamp(0, 1).cpu(), ground.clamp(0, 1).cpu()


def hex_colour(rgb: Tensor) -> str:
    """'#rrggbb' of an RGB colour (3,) in [0, 1]."""
    return "#{:02x}{:02x}{:02x}".format(*(int(round(255 * float(c))) for c in rgb))


def texton_exemplar(textons: Textons, rows: Tensor, kinds: Tensor, colours: Tensor):
    """The cvt exemplar of the element textons ``rows`` (cvt.gaussians), with appearance
    attributes [one-hot kind, colour] (seed 000 sec. 4.2). Shape: rows, kinds (E,), colours
    (K, 3)."""
    from cvt.gaussians import gaussian_exemplar

    names, k = torch.unique(kinds, return_inverse=True)
    onehot = torch.eye(len(names), dtype=torch.float64)[k]  # (E, kinds)
    rgb = colours[rows].double()  # (E, 3)
    fills = [hex_colour(col) for col in rgb]
    return gaussian_exemplar(textons.mu[0, rows].detach().cpu().double().numpy(),
                             textons.cov[0, rows].detach().cpu().double().numpy(),
                             torch.cat([onehot, 2 * rgb], 1).numpy(), textons.canvas, fills)


def arrange(textons: Textons, canvas: tuple[float, float], colours: tuple[Tensor, Tensor],
            settings: ArrangeSettings = ArrangeSettings(),
            on_iteration: Callable | None = None, channels: int | None = None) -> Arrangement:
    """Arrange one texton set (1, K) on ``canvas`` = (w, h) (normalized units of the input:
    the elements keep their size) with cvt's engine. ``colours``: (per texton (K, 3), ground
    (3,)) (:func:`texton_colours`); ``channels``: see :func:`layers`."""
    from cvt.pattern import PatternOptions, synthesize_pattern
    from cvt.synthesis import SynthesisConfig
    from neuraltex.errors import InputError

    elems, kinds, back = layers(textons, settings.seed, channels)
    if len(elems) < 2:
        raise InputError(f"the texture has {len(elems)} element texton(s) besides its "
                         "background: nothing to arrange")
    colours, ground = colours
    ex = texton_exemplar(textons, elems, kinds, colours)
    cfg = SynthesisConfig(levels=len(settings.deltas), iterations=settings.iterations,
                          deltas=settings.deltas, radii=settings.radii, seed=settings.seed,
                          init=settings.init, w_a=settings.w_a)
    opts = PatternOptions(lattice=False, density=settings.density, tileable=settings.tileable,
                          kinds=kinds.numpy())
    pattern = synthesize_pattern(ex, canvas, cfg, settings.method, opts, on_iteration)
    placed = pattern.placements
    if settings.tileable:  # one copy each (centre on the canvas); the decode wraps around
        placed = [p for p in placed if _centred(ex.elements[p[0]].bbox, p, canvas)]
    out = place(textons, elems, placed, back, canvas)
    fill = hex_colour(colours[back[0]] if len(back) else ground)
    return Arrangement(out, ex, placed, elems, back, pattern.placements, fill, pattern.notes,
                       pattern.result)


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
    shift = torch.tensor([[p[1], p[2]] for p in placed], dtype=textons.dtype)  # (P, 2)
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


def synthesize_texture(decoder, textons: Textons, short: int, size: tuple[int, int],
                       settings: ArrangeSettings = ArrangeSettings(),
                       on_iteration: Callable | None = None) -> tuple[Tensor, Arrangement]:
    """(picture (3, H, W), arrangement) of a texture grown to ``size`` = (H, W) at the
    input's pixel pitch (``short`` px per normalized unit): arrange, then decode."""
    colours = texton_colours(decoder, textons, short)
    canvas = (size[1] / short, size[0] / short)
    arr = arrange(textons, canvas, colours, settings, on_iteration,
                  decoder.generator.feature_channels - 2)
    image = decode_arranged(decoder, arr.textons, size, settings.tileable, len(arr.background))
    return image, arr
