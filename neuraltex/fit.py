"""Tune the decoder to one texture: sharp reconstructions and edits of a real image on a CPU.

A general model trained for a few CPU-hours cannot be sharp on every texture; tuned to one, it
can (the pivotal-tuning idea of GAN inversion: invert, then tune the generator around the
inversion). Here:

1. masks S come from a segmenter (:mod:`neuraltex.segmenters`), at full resolution;
2. E_g (eqs. 4.3-4.7) estimates one Gaussian texton per mask from the frozen E_FC's maps, and
   the painter's order puts larger Gaussians behind (eq. 4.13);
3. the textons' appearance features f (unit vectors, eq. 4.6) and the SPADE generator G are
   optimized together for L1 + L2 reconstruction of random crops of the image, rendered through
   the splatting h (eqs. 4.11-4.14) in a random dihedral pose (flips, transpose), so G learns to
   render textons, not one fixed picture;
4. the textons are grouped into elements, the objects they make together
   (:mod:`neuraltex.texton_elements`), so a reshuffle can move whole objects;
5. what G still misses is fitted, by least squares, as a small RGB sprite per texton in its
   own frame (:mod:`neuraltex.texton_detail`): appearance that moves with the texton, fitted
   to the texture and, lightly, to layouts in which its elements trade places.

E_FC and E_s stay frozen, so features of every tuned texture live in the base model's feature
space (transfer and interpolation between texture files stay meaningful), and a texture is
stored as its textons plus the change of G (:mod:`neuraltex.texture_file`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from neuraltex.estimation import estimate_textons, painter_order
from neuraltex.fit_prior import start_generator
from neuraltex.nn_utils import adam, resize
from neuraltex.segmenters import MAX_SEGMENTS, METHODS, segment_labels, soft_masks
from neuraltex.splatting import splat
from neuraltex.texton_detail import DetailSampler, attach, auto_side, fit_sprites
from neuraltex.texton_elements import group_textons, swapped_layout
from neuraltex.textons import Textons
from neuraltex.tuned_decoder import ColourOffsetGenerator

SEGMENTERS = ("auto", *METHODS)
SWAPPED_LAYOUTS = 2    # layouts with elements traded that the detail sprites also fit ...
SWAPPED_WEIGHT = 0.1   # ... each weighted this much against the texture itself
# the work after the tuning (elements, sprites) takes about this many times the work before
# it (segments, first estimate), on a quiet machine as on a busy one (measured: 3-5 s after
# 2-3 s quiet; 15-37 s after at load 4)
AFTER_TUNING = 2.0


@dataclass
class FitSettings:
    segmenter: str = "auto"
    seconds: float | None = 55.0  # wall-time budget of the whole fit: segments, tuning,
    #                               elements, sprites (the tuning gets what the rest leaves,
    #                               tuning_budget); None: steps only
    steps: int | None = None      # step budget (reproducible for a seed); None: seconds only
    crop: int = 64                # side of the random training crops, pixels
    lr: float = 2e-3              # G
    lr_features: float = 2e-2     # f_a
    lr_offsets: float = 2e-2      # d, the colour offsets (neuraltex.tuned_decoder)
    max_textons: int = MAX_SEGMENTS
    queries: int | None = None    # segmenter "model": E_s's queries resampled to this many
    dihedral: bool = False        # random flips / transposes of image and textons
    ground: bool = False          # merge the ground between elements into one background
    #                               layer (looks cleaner on spots, costs PSNR on grout)
    eval_every: int = 25          # steps between full-image PSNR readings
    detail: int | None = None     # side of each texton's detail sprite (None: by the
    #                               texton count, texton_detail.auto_side; 0: no sprites)
    prior: bool = True            # start G from the model's fit prior when it has one
    #                               (neuraltex.fit_prior); False: from the model's own G
    seed: int = 0


@dataclass
class TextureFit:
    textons: Textons        # (1, K) textons, f = [f_a, d] (neuraltex.tuned_decoder)
    labels: np.ndarray      # (H, W) int64 segment of each pixel (texton index)
    generator: dict[str, Tensor]  # tuned parameters of G, by name
    segmenter: str          # the method used (what ``auto`` picked)
    steps: int
    seconds: float
    psnr: float             # of the final full-size reconstruction, dB
    detail: int             # side of the textons' detail sprites (0: none)
    base_psnr: float        # before tuning (the textons' colours already set), dB
    plain_psnr: float       # after tuning G, before the detail sprites, dB
    detail_seconds: float   # fitting the sprites
    elements: np.ndarray | None = None  # (K,) element of each texton (neuraltex.texton_elements)


def psnr(x: Tensor, y: Tensor) -> float:
    return 10 * math.log10(1 / max(F.mse_loss(x, y).item(), 1e-12))


def choose_segments(model, image: Tensor, method: str, max_textons: int,
                    ground: bool = False, queries: int | None = None
                    ) -> tuple[str, Textons, np.ndarray]:
    """(method, textons, labels) for an image (3, H, W). ``auto`` tries Felzenszwalb and SLIC
    (at Felzenszwalb's segment count) and keeps the one whose textons, splatted with their
    segments' mean colours (eqs. 4.3-4.7, 4.11-4.14), come closest to the image (PSNR): the
    segments that the Gaussians can represent best."""
    if method != "auto":
        labels = segment_labels(image, method, model=model, max_segments=max_textons,
                                queries=queries)
        return (method, *initial_textons(model, image, labels, ground))
    best = None
    count = None
    for name in ("felzenszwalb", "slic"):
        labels = segment_labels(image, name, max_segments=max_textons, count=count)
        count = int(labels.max()) + 1
        textons, labels = initial_textons(model, image, labels, ground)
        score = colour_splat_psnr(model, image, textons, labels)
        if best is None or score > best[0]:
            best = (score, name, textons, labels)
    return best[1:]


def colour_splat_psnr(model, image: Tensor, textons: Textons, labels: np.ndarray) -> float:
    """PSNR of the textons splatted with their segments' mean colours as features."""
    colours = segment_means(image, labels)  # (1, K, 3)
    with torch.no_grad():
        s = splat(replace(textons, f=colours), tuple(image.shape[-2:]), cutoff=model.cutoff)
    return psnr(s.features[0, :3].clamp(0, 1), image)


def initial_textons(model, image: Tensor, labels: np.ndarray,
                    ground: bool = False) -> tuple[Textons, np.ndarray]:
    """Textons of an image (3, H, W) from hard segment labels (H, W): eqs. 4.3-4.7 on soft
    masks at full resolution with the frozen E_FC's maps, every texton existing (delta = 1),
    larger ones behind. With ``ground`` the ground between elements becomes one background
    layer (:func:`ground_labels`); returns the textons and the labels they were estimated
    from."""
    if ground:
        labels, ground = ground_labels(labels, image)
    t = _estimate(model, image, labels)
    if ground:
        t = background_layer(t, 0)
    return replace(t, order=painter_order(t.cov)), labels


def _estimate(model, image: Tensor, labels: np.ndarray) -> Textons:
    H, W = image.shape[-2:]
    masks = soft_masks(labels).to(image.device)  # (1, K, H, W)
    with torch.no_grad():
        appearance, direction = model.encoder(image[None] * 2 - 1)
        appearance, direction = resize(appearance, (H, W)), resize(direction, (H, W))
        return estimate_textons(masks, appearance, direction, existence="all", eps=model.config.eps)


def ground_labels(labels: np.ndarray, image: Tensor, share: float = 0.05, fill: float = 0.75,
                  colour: float = 0.1) -> tuple[np.ndarray, bool]:
    """Merge the *ground* into label 0: segments whose Gaussian would spread over at least
    ``share`` of the image while their pixels fill less than ``fill`` of it (grout, the
    ground between spots: sprawling, not element-shaped) and whose mean colour is within
    ``colour`` (RGB distance) of the largest such segment's; the other labels follow from 1.
    Shape (H, W) -> (H, W), and whether there was ground (else the labels are unchanged)."""
    H, W = image.shape[-2:]
    ys, xs = torch.meshgrid(torch.arange(H, dtype=torch.float64),
                            torch.arange(W, dtype=torch.float64), indexing="ij")
    maps = torch.stack([xs, ys, xs * xs, ys * ys, xs * ys, *image.cpu().double()])  # (8, H, W)
    mx, my, mxx, myy, mxy, *rgb = segment_means(maps, labels)[0].T  # (K,) each
    lab = torch.from_numpy(np.ascontiguousarray(labels)).long()
    n = torch.bincount(lab.flatten(), minlength=len(mx)).double()
    cov_det = (mxx - mx ** 2) * (myy - my ** 2) - (mxy - mx * my) ** 2
    spread = 4 * math.pi * cov_det.clamp_min(0).sqrt()  # pixels
    ground = (spread >= share * H * W) & (n < fill * spread)
    if ground.any():
        rgb = torch.stack(rgb, 1)  # (K, 3)
        largest = int(torch.where(ground, n, torch.zeros_like(n)).argmax())
        ground &= (rgb - rgb[largest]).norm(dim=1) < colour
    if not ground.any():
        return labels, False
    new = torch.cumsum(~ground, 0)  # non-ground labels -> 1..K'
    new[ground] = 0
    return new[lab].numpy(), True


def background_layer(textons: Textons, k: int = 0, cover: float = 10.0) -> Textons:
    """Texton ``k`` becomes the background layer: a Gaussian ``cover`` times the canvas,
    centred on it, so it is opaque everywhere behind the elements instead of a blob that
    fades towards the corners."""
    w, h = textons.canvas
    mu, cov = textons.mu.clone(), textons.cov.clone()
    mu[0, k] = mu.new_tensor([w / 2, h / 2])
    cov[0, k] = torch.diag(cov.new_tensor([(cover * w) ** 2, (cover * h) ** 2]))
    return replace(textons, mu=mu, cov=cov)


def dihedral(image: Tensor, textons: Textons, code: int) -> tuple[Tensor, Textons]:
    """One of the 8 flips/transposes (bits: flip x, flip y, transpose) applied to an image
    (3, H, W) and its textons alike."""
    w, h = textons.canvas
    if code & 1:
        image = image.flip(-1)
        textons = textons.affine(torch.tensor([[-1.0, 0.0], [0.0, 1.0]]), (w, 0.0))
    if code & 2:
        image = image.flip(-2)
        textons = textons.affine(torch.tensor([[1.0, 0.0], [0.0, -1.0]]), (0.0, h))
    if code & 4:
        image = image.transpose(-1, -2)
        textons = replace(textons.affine(torch.tensor([[0.0, 1.0], [1.0, 0.0]])), canvas=(h, w))
    return image, textons


def fit_texture(model, image: Tensor, settings: FitSettings | None = None,
                bar: bool | None = None,
                on_eval: Callable[[int, float, float], None] | None = None) -> TextureFit:
    """Tune G and the textons' features to an image (3, H, W) in [0, 1]; returns the fit.

    Stops tuning after ``settings.steps`` steps or when the whole fit would run over
    ``settings.seconds`` (:func:`tuning_budget`), whichever comes first.
    ``on_eval(step, seconds, psnr)`` is called at every full-image PSNR reading (step 0 and
    every ``eval_every`` steps), e.g. to record the climb.
    """
    from tqdm import tqdm

    cfg = settings or FitSettings()
    if cfg.steps is None and cfg.seconds is None:
        raise ValueError("fit needs a step or a time budget")
    begin = time.perf_counter()
    method, textons, labels = choose_segments(model, image, cfg.segmenter, cfg.max_textons,
                                              cfg.ground, cfg.queries)
    rng = torch.Generator().manual_seed(cfg.seed)
    G = ColourOffsetGenerator(start_generator(model, cfg.prior)).eval()  # eval: keep BN stats
    current, opt = tuning(G, textons, first_offsets(model, image, textons, labels), cfg)
    progress = tqdm(total=cfg.steps, desc="fit", unit="step", leave=False,
                    disable=None if bar is None else not bar)
    budget = tuning_budget(cfg.seconds, time.perf_counter() - begin)
    start, step = time.perf_counter(), 0
    base = score = _full_psnr(model, G, image, current())
    if on_eval:
        on_eval(0, 0.0, score)
    while not _done(cfg.steps, budget, step, time.perf_counter() - start):
        tuning_step(model, G, image, current(), opt, cfg, rng)
        step += 1
        if step % cfg.eval_every == 0:
            score = _full_psnr(model, G, image, current())
            progress.set_postfix(psnr=f"{score:.2f} dB")
            if on_eval:
                on_eval(step, time.perf_counter() - start, score)
        progress.update(1)
    seconds = time.perf_counter() - start
    progress.close()
    fitted = current().detach()
    plain = score = _full_psnr(model, G, image, fitted)
    start = time.perf_counter()
    elements = group_textons(image, labels, fitted)
    H, W = image.shape[-2:]
    side = auto_side(fitted.num_textons, (H, W)) if cfg.detail is None else cfg.detail
    if side:
        fitted = fit_detail(model, G, image, fitted, side, labels, elements)
        score = _full_psnr(model, G, image, fitted)
    tuned = {k: v.detach().clone() for k, v in G.generator.named_parameters()}
    return TextureFit(fitted, labels, tuned, method, step, seconds, score, side, base, plain,
                      time.perf_counter() - start, elements)


def first_offsets(model, image: Tensor, textons: Textons, labels: np.ndarray) -> Tensor:
    """The colour offsets d (1, K, 3) tuning starts from: each segment's mean colour minus
    the mean of the base model's decode there, so colours are right from the first step."""
    with torch.no_grad():
        first = model.decode(textons, tuple(image.shape[-2:]))[0]  # (3, H, W)
    return segment_means(image - first, labels)


def tuning(G: nn.Module, textons: Textons, offsets: Tensor, cfg: FitSettings
           ) -> tuple[Callable[[], Textons], torch.optim.Optimizer]:
    """What step 3 optimizes: G's parameters (requires_grad on), the textons' appearance f_a
    (kept unit length, eq. 4.6) and their colour offsets d, with Adam. Returns (current
    textons with f = [f_a, d], the optimizer)."""
    for p in G.parameters():
        p.requires_grad_(True)
    fa = nn.Parameter(textons.f.detach().clone())
    d = nn.Parameter(offsets.detach().clone())
    opt = adam([{"params": list(G.parameters()), "lr": cfg.lr},
                {"params": [fa], "lr": cfg.lr_features},
                {"params": [d], "lr": cfg.lr_offsets}])
    return (lambda: replace(textons, f=torch.cat([F.normalize(fa, dim=-1), d], dim=-1))), opt


def tuning_step(model, G: nn.Module, image: Tensor, textons: Textons,
                opt: torch.optim.Optimizer, cfg: FitSettings, rng: torch.Generator) -> float:
    """One Adam step of the tuning on a random crop (:func:`_crop_loss`); returns the loss."""
    loss = _crop_loss(model, G, image, textons, cfg, rng)
    opt.zero_grad(set_to_none=True)
    loss.backward()
    opt.step()
    return loss.item()


def fit_detail(model, G: nn.Module, image: Tensor, textons: Textons, side: int,
               labels: np.ndarray | None = None, elements: np.ndarray | None = None
               ) -> Textons:
    """The textons with detail sprites (``side`` texels) fitted to what G's decode misses:
    f -> [f, vec(D)] (:mod:`neuraltex.texton_detail`). With the ``labels`` and ``elements``,
    the sprites also fit SWAPPED_LAYOUTS layouts in which the elements trade places, weighted
    SWAPPED_WEIGHT (:func:`neuraltex.texton_elements.swapped_layout`): the detail must then
    move with its element instead of staying in the ground where the element was. Measured
    (2 layouts, weight 0.1, 3 real textures): the reconstruction's patch-SWD drops a little
    (coins 50.7 -> 48.5, stone_wall 328 -> 307, leopard 241 -> 230) and a reshuffle's more
    (210 -> 169, 443 -> 421, 294 -> 263)."""
    H, W = image.shape[-2:]
    layouts = [(textons, image, None)]
    if elements is not None and labels is not None:
        layouts += [(moved, target, SWAPPED_WEIGHT * known) for moved, target, known in
                    (swapped_layout(image, labels, elements, textons, seed=101 + i)
                     for i in range(SWAPPED_LAYOUTS))]
    samplers, residuals = [], []
    for t, target, _ in layouts:
        with torch.no_grad():
            residuals.append((target - model.decode(t, (H, W), generator=G)[0])[None])
        samplers.append(DetailSampler(t, (H, W), cutoff=model.cutoff))
    sprites = fit_sprites(samplers, residuals, [w for *_, w in layouts], side)
    return attach(textons, sprites.detach())


def tuning_budget(seconds: float | None, before: float) -> float | None:
    """Seconds of tuning within a whole-fit budget of ``seconds``, ``before`` of them spent
    on the segments and the first estimate: what is left once the work after the tuning
    (AFTER_TUNING times ``before``) is set aside; None without a budget. At least one step
    is always taken."""
    if seconds is None:
        return None
    return max(seconds - before * (1 + AFTER_TUNING), 0.0)


def _done(steps: int | None, seconds: float | None, step: int, elapsed: float) -> bool:
    return step >= 1 and ((steps is not None and step >= steps)
                          or (seconds is not None and elapsed >= seconds))


def segment_means(x: Tensor, labels: np.ndarray) -> Tensor:
    """Mean of a map x (C, H, W) over each segment of ``labels`` (H, W) -> (1, K, C)."""
    lab = torch.from_numpy(np.ascontiguousarray(labels)).long().flatten().to(x.device)
    K = int(lab.max()) + 1
    sums = torch.zeros(K, x.shape[0], dtype=x.dtype, device=x.device)
    sums.index_add_(0, lab, x.flatten(1).T)
    count = torch.bincount(lab, minlength=K).clamp_min(1).to(x.dtype)
    return (sums / count[:, None])[None]


def _crop_loss(model, G: nn.Module, image: Tensor, textons: Textons, cfg: FitSettings,
               rng: torch.Generator) -> Tensor:
    """L1 + L2 between a random crop of the image and the decode of the same window, both in
    a random dihedral pose."""
    code = int(torch.randint(8, (1,), generator=rng)) if cfg.dihedral else 0
    img, t = dihedral(image, textons, code)
    H, W = img.shape[-2:]
    ch, cw = min(cfg.crop, H), min(cfg.crop, W)
    y0 = int(torch.randint(H - ch + 1, (1,), generator=rng))
    x0 = int(torch.randint(W - cw + 1, (1,), generator=rng))
    s = min(H, W)  # coords: short side = 1
    window = (x0 / s, y0 / s, (x0 + cw) / s, (y0 + ch) / s)
    out = model.decode(t, (ch, cw), window=window, generator=G)[0]  # (3, ch, cw)
    target = img[:, y0:y0 + ch, x0:x0 + cw]
    return F.l1_loss(out, target) + F.mse_loss(out, target)


def _full_psnr(model, G: nn.Module, image: Tensor, textons: Textons) -> float:
    with torch.no_grad():
        return psnr(model.decode(textons, tuple(image.shape[-2:]), generator=G)[0], image)
