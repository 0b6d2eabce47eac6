"""Quantitative metrics between an exemplar and a synthesized pattern (no learned weights).

A layout is a list of placed input elements (element, dx, dy) in drawing order over a box; the
exemplar is the layout of its own elements, untranslated. Element kinds are the elements' tag
structure (``circle``, ``g(path,path)``...), so recolored or rotated copies of one motif share a
kind. Metrics, lower is better unless noted:

1. ``pcf``: multi-class pair correlation functions of element centers (each kind and each pair
   of kinds, translation edge correction), mean absolute difference to the exemplar's.
2. ``local``: mean distance of each output neighborhood to its nearest exemplar neighborhood
   (seed 000 eq. 2 at the finest level, divided by the neighborhood's sample count, averaged over
   neighborhoods: seed 000 Fig. 10's normalization).
3. composition: ``coverage`` |filled-area ratio difference|, ``density`` |relative element
   count per area difference|, ``overlap`` |difference in the share of covered area that
   two or more elements cover|, ``duplicates`` share of elements that a same-kind element
   overlaps more than any same-kind pair of the exemplar does (+0.1).
4. ``layering`` (higher is better): share of overlapping element pairs of two kinds drawn in
   the order the exemplar uses for those kinds (kind pairs with a clear rule, >= 80 %).
5. ``appearance``: sliced Wasserstein distance of multi-scale 4x4 pixel patches of the
   renders (neuraltex.losses.sliced_wasserstein_patches), times 1000.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import torch

from cvt.raster import Mask, element_mask, overlap, render_svg
from cvt.svg import Element, Exemplar, to_svg


def kind_of(element: Element) -> str:
    def sig(node) -> str:
        kids = [sig(c) for c in node]
        return node.tag.rsplit("}", 1)[-1] + (f"({','.join(kids)})" if kids else "")

    return sig(element.node)


@dataclass
class Layout:
    exemplar: Exemplar
    placements: list[tuple[int, float, float]]  # (element, dx, dy), bottom to top
    size: tuple[float, float]  # width, height from the exemplar's viewBox origin
    scale: float = 1.0  # raster pixels per user unit

    @staticmethod
    def of_exemplar(ex: Exemplar, scale: float = 1.0) -> Layout:
        return Layout(ex, [(e.index, 0.0, 0.0) for e in ex.elements], tuple(ex.viewbox[2:]),
                      scale)

    @property
    def origin(self) -> np.ndarray:
        return np.array(self.exemplar.viewbox[:2], dtype=float)

    @property
    def area(self) -> float:
        return self.size[0] * self.size[1]

    @cached_property
    def kinds(self) -> list[str]:
        names = [kind_of(e) for e in self.exemplar.elements]
        return [names[e] for e, _, _ in self.placements]

    @cached_property
    def centers(self) -> np.ndarray:
        """Element bounding-box centers. Shape: (P, 2)."""
        if not self.placements:
            return np.zeros((0, 2))
        b = np.stack([self.exemplar.elements[e].bbox for e, _, _ in self.placements])
        return (b[:, :2] + b[:, 2:]) / 2 + np.array([[dx, dy] for _, dx, dy in self.placements])

    @cached_property
    def masks(self) -> list[Mask]:
        return [element_mask(self.exemplar.elements[e], dx, dy, self.origin, self.scale)
                for e, dx, dy in self.placements]

    @cached_property
    def overlaps(self) -> list[tuple[int, int, int]]:
        """(i, j, shared pixels) for element pairs i < j that overlap."""
        out = []
        m = self.masks
        box = np.array([[k.x0, k.y0, k.x0 + k.pixels.shape[1], k.y0 + k.pixels.shape[0]]
                        for k in m]).reshape(-1, 4)
        for i in range(len(m)):
            near = np.flatnonzero((box[i + 1 :, 0] < box[i, 2]) & (box[i + 1 :, 2] > box[i, 0])
                                  & (box[i + 1 :, 1] < box[i, 3]) & (box[i + 1 :, 3] > box[i, 1]))
            for j in near + i + 1:
                px = overlap(m[i], m[int(j)])
                if px > 0:
                    out.append((i, int(j), px))
        return out

    @cached_property
    def image(self) -> np.ndarray:
        return render_svg(to_svg(self.exemplar, self.placements, self.size))  # (H, W, 3)

    @cached_property
    def counts(self) -> np.ndarray:
        """How many elements cover each pixel. Shape: (H, W)."""
        w, h = (round(s * self.scale) for s in self.size)
        cnt = np.zeros((h, w), dtype=np.int32)
        for k in self.masks:
            y0, x0 = max(k.y0, 0), max(k.x0, 0)
            y1, x1 = min(k.y0 + k.pixels.shape[0], h), min(k.x0 + k.pixels.shape[1], w)
            if y1 > y0 and x1 > x0:
                cnt[y0:y1, x0:x1] += k.pixels[y0 - k.y0 : y1 - k.y0, x0 - k.x0 : x1 - k.x0]
        return cnt


# -- 1. element distribution ---------------------------------------------------------------
def pair_correlation(a: np.ndarray, b: np.ndarray, size, radii: np.ndarray, sigma: float,
                     same: bool) -> np.ndarray:
    """Cross pair correlation g_ab(r) with a Gaussian kernel and translation edge correction.

    Shape: a (A, 2), b (B, 2), radii (R,) -> (R,).
    """
    w, h = size
    if len(a) == 0 or len(b) == 0 or (same and len(a) < 2):
        return np.zeros(len(radii))
    d = a[:, None, :] - b[None, :, :]  # (A, B, 2)
    dist = np.linalg.norm(d, axis=-1)
    weight = 1.0 / np.maximum((w - np.abs(d[..., 0])) * (h - np.abs(d[..., 1])), 1e-9)
    ok = dist < radii[-1] + 3 * sigma
    if same:
        ok &= ~np.eye(len(a), dtype=bool)
    dist, weight = dist[ok], weight[ok]
    kern = np.exp(-0.5 * ((radii[:, None] - dist[None]) / sigma) ** 2) / (np.sqrt(2 * np.pi)
                                                                         * sigma)
    n_b = len(b) - 1 if same else len(b)
    lam = len(a) * n_b / (w * h) ** 2  # product of intensities
    return (kern * weight[None]).sum(1) / (2 * np.pi * radii * lam)


def pcf_distance(ref: Layout, out: Layout, bins: int = 24) -> float:
    """Mean |g_ref - g_out| over radii up to a quarter of the exemplar size, per kind pair."""
    reach = ref.exemplar.size / 4
    radii = np.linspace(reach / bins, reach, bins)
    sigma = reach / bins
    kinds = sorted(set(ref.kinds))
    k_ref, k_out = np.array(ref.kinds), np.array(out.kinds, dtype=object)
    diffs = []
    for i, ka in enumerate(kinds):
        for kb in kinds[i:]:
            g = [pair_correlation(lay.centers[k == ka], lay.centers[k == kb], lay.size, radii,
                                  sigma, ka == kb)
                 for lay, k in ((ref, k_ref), (out, k_out))]
            diffs.append(np.abs(g[0] - g[1]).mean())
    return float(np.mean(diffs))


# -- 2. local structure --------------------------------------------------------------------
def local_energy(ex: Exemplar, out: Layout, passes: int = 6, seed: int = 0) -> float:
    """Seed 000 eq. 2 of each output neighborhood to its nearest exemplar neighborhood at the finest
    level, over the neighborhood's sample count, averaged (lower: more exemplar-like)."""
    from cvt.reconstruction import Placement, upsample
    from cvt.sampling import hierarchy, sample_exemplar
    from cvt.synthesis import SynthesisConfig, nearest_neighborhoods

    cfg = SynthesisConfig()
    lv = hierarchy(ex.size, cfg.levels, cfg.deltas, cfg.radii)[-1]
    inp = sample_exemplar(ex, lv.delta, seed=seed)
    if not out.placements:
        return float("nan")
    samples = upsample([Placement(k, e, dx, dy, 0.0, 0) for k, (e, dx, dy)
                        in enumerate(out.placements)], inp)
    vx, vy, vw, vh = ex.viewbox
    gen = torch.Generator().manual_seed(seed)
    m = nearest_neighborhoods(samples, inp, (vx, vy, vx + vw, vy + vh), lv, cfg, passes, gen)
    size = 1 + (m.out_nbr >= 0).sum(1)
    return float((m.cost / size).mean())


# -- 3. composition ------------------------------------------------------------------------
def _same_kind_cover(lay: Layout) -> np.ndarray:
    """Per element: the largest share of its area one same-kind element covers. Shape: (P,)."""
    share = np.zeros(len(lay.placements))
    area = np.array([max(m.area, 1) for m in lay.masks])
    for i, j, px in lay.overlaps:
        if lay.kinds[i] == lay.kinds[j]:
            share[i] = max(share[i], px / area[i])
            share[j] = max(share[j], px / area[j])
    return share


def composition(ref: Layout, out: Layout) -> dict[str, float]:
    def coverage(lay):
        return float((lay.counts > 0).mean())

    def multi(lay):
        covered = (lay.counts > 0).sum()
        return float((lay.counts > 1).sum() / max(covered, 1))

    def density(lay):
        c = lay.centers
        x0, y0 = lay.origin
        inside = ((c[:, 0] >= x0) & (c[:, 0] < x0 + lay.size[0]) & (c[:, 1] >= y0)
                  & (c[:, 1] < y0 + lay.size[1]))
        return inside.sum() / lay.area

    limit = min(float(_same_kind_cover(ref).max(initial=0.0)) + 0.1, 0.95)
    dup = _same_kind_cover(out)
    return {
        "coverage": abs(coverage(out) - coverage(ref)),
        "density": abs(density(out) / density(ref) - 1),
        "overlap": abs(multi(out) - multi(ref)),
        "duplicates": float((dup > limit).mean()) if len(dup) else 0.0,
    }


# -- 4. layering ---------------------------------------------------------------------------
def _pair_orders(lay: Layout, min_share: float = 0.02):
    """(lower kind, upper kind) of each overlapping cross-kind pair, by drawing order."""
    area = [max(m.area, 1) for m in lay.masks]
    for i, j, px in lay.overlaps:  # i < j: j is drawn above i
        if lay.kinds[i] != lay.kinds[j] and px >= min_share * min(area[i], area[j]):
            yield lay.kinds[i], lay.kinds[j]


def layering(ref: Layout, out: Layout, clear: float = 0.8) -> float:
    """Share of overlapping cross-kind output pairs in the exemplar's order (nan: none)."""
    votes: dict[tuple[str, str], list[int]] = {}
    for lo, hi in _pair_orders(ref):
        key = tuple(sorted((lo, hi)))
        votes.setdefault(key, [0, 0])[int(lo == key[0])] += 1  # [1]: key[0] below key[1]
    rule = {k: v[1] / sum(v) >= 0.5 for k, v in votes.items()
            if max(v) >= clear * sum(v)}  # True: key[0] below key[1]
    agree = total = 0
    for lo, hi in _pair_orders(out):
        key = tuple(sorted((lo, hi)))
        if key in rule:
            total += 1
            agree += rule[key] == (lo == key[0])
    return agree / total if total else float("nan")


# -- 5. appearance -------------------------------------------------------------------------
def appearance(ref: Layout, out: Layout, seed: int = 0) -> float:
    return patch_swd(out.image, ref.image, seed)


def patch_swd(a: np.ndarray, b: np.ndarray, seed: int = 0) -> float:
    """Sliced Wasserstein distance of multi-scale 4x4 patches of two RGB images, x 1000.
    Shape: (H, W, 3), (H', W', 3) float in [0, 1]."""
    from neuraltex.losses import sliced_wasserstein_patches

    x = torch.from_numpy(np.ascontiguousarray(a, np.float32)).permute(2, 0, 1)[None]
    y = torch.from_numpy(np.ascontiguousarray(b, np.float32)).permute(2, 0, 1)[None]
    gen = torch.Generator().manual_seed(seed)
    return 1000 * float(sliced_wasserstein_patches(x, y, patch=4, projections=64, scales=3,
                                                   generator=gen))


def all_metrics(ex: Exemplar, out: Layout, ref: Layout | None = None) -> dict[str, float]:
    ref = ref or Layout.of_exemplar(ex, out.scale)
    return {"pcf": pcf_distance(ref, out), "local": local_energy(ex, out),
            **composition(ref, out), "layering": layering(ref, out),
            "appearance": appearance(ref, out)}


def broken_fraction(res, delta: float) -> float:
    """Share of final output clusters that are not one whole element: fewer than half or more
    than 1.5x the samples of their best input cluster (seed 000 eq. 15), counted before filtering.
    ``res`` is a SynthesisResult; nan for methods without clusters."""
    from cvt.reconstruction import reconstruct

    if not res.outputs:
        return float("nan")
    out, inp, m = res.outputs[-1], res.inputs[-1], res.matches[-1]
    full = torch.bincount(inp.cluster)
    ratio = np.array([p.size / float(full[p.element]) for p in reconstruct(out, inp, m, delta)])
    return float(((ratio < 0.5) | (ratio > 1.5)).mean()) if len(ratio) else float("nan")
