"""The real-world judge: where an output SVG sits between two references of its exemplar.

R1 (bad end) is the exemplar's elements at random places at its density, R2 (good end) the
exemplar tiled 2 x 2; both over the same background, at the output's size. For each metric D
(a distance to the exemplar) the output passes when it is closer to R2's value than to R1's,
D(out) <= (D(R1) + D(R2)) / 2. Where the references do not separate (D(R1) <= D(R2): random
placement is as exemplar-like as the tiling on that metric, e.g. overlap on a sparse layout
with no overlaps), the metric cannot tell good from bad there and the output passes when it
lies within the references' range, D(out) <= D(R2); such cases are counted and reported.
Metrics, read from the SVG files alone (copies are recognized by their markup, kinds by
cvt.kinds):

* ``pcf``: pair-correlation distance of element centres per kind pair (cvt.metrics);
* ``swd``: patch SWD (x 1000) of the renderings, at one pixel scale for all;
* ``degree``: |mean number of elements each element overlaps - the exemplar's|;
* ``depth``: L1 distance of the shares of covered pixels under 1, 2, 3+ elements;
* ``layering``: 1 - share of overlapping cross-kind pairs drawn in the exemplar's order;
* ``density``: worst |count per area / the exemplar's - 1| over whole kinds (centres inside);
* ``integrity``: share of output elements that are whole motifs on the canvas (not a fragment
  copy away from the border, not entirely off the canvas);
* ``pairs``: worst ratio, over companion kinds that touch another kind in >= 50 % of cases in
  the exemplar (a butterfly on a heart, leaves by a flower), of the output's rate to the
  exemplar's (on a tileable output, as tiled: across the seam too).
"""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from cvt.companions import touches
from cvt.density import fragment_owners, kind_counts
from cvt.kinds import cut_mask, element_kinds
from cvt.metrics import Layout, layering, patch_swd, pcf_distance
from cvt.svg import SVG_NS, Exemplar, to_svg
from cvt.torus import Torus

PASS_METRICS = ("pcf", "swd", "depth", "degree", "layering")
PIXELS = 128  # render width of the exemplar; outputs at the same pixels per user unit
_SUFFIX = re.compile(r"-c\d+\b")


class KindLayout(Layout):
    """A layout whose kinds are cvt.kinds ids (shape and paint), not tag structure."""

    kind_ids: np.ndarray | None = None

    @cached_property
    def kinds(self) -> list[str]:
        return [f"k{self.kind_ids[e]}" for e, _, _ in self.placements]


def layout(ex: Exemplar, kind_ids, placements, size, scale) -> KindLayout:
    lay = KindLayout(ex, placements, size, scale)
    lay.kind_ids = kind_ids
    return lay


def placements_of(svg_text: str, ex: Exemplar) -> list[tuple[int, float, float]]:
    """(element, dx, dy) of the copies in an output SVG, recognized by their markup."""
    by_markup = {_key(e.node): e.index for e in ex.elements}
    root = ET.fromstring(re.sub(r"^<\?xml[^>]*\?>\s*", "", svg_text))
    out = []
    for g in root.iter(f"{{{SVG_NS}}}g"):
        m = re.fullmatch(r"translate\(([-\d.e+]+),([-\d.e+]+)\)", g.get("transform", ""))
        if m is None or len(g) != 1:
            continue
        idx = by_markup.get(_key(g[0], strip=True))
        if idx is not None:
            out.append((idx, float(m.group(1)), float(m.group(2))))
    return out


def _key(node: ET.Element, strip: bool = False) -> str:
    text = ET.tostring(node, encoding="unicode")
    return _SUFFIX.sub("", text) if strip else text


@dataclass
class Scene:
    """An SVG (exemplar, output or reference) read against its exemplar."""

    svg: str
    lay: KindLayout
    scale: float

    @cached_property
    def image(self) -> np.ndarray:
        from PIL import Image

        from cvt.raster import png_bytes

        w = max(1, round(self.lay.size[0] * self.scale))
        png = png_bytes(self.svg, width=w)
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.float32) / 255

    @cached_property
    def degree(self) -> float:
        n = len(self.lay.placements)
        return 2 * len(self.lay.overlaps) / max(n, 1)

    @cached_property
    def depth(self) -> np.ndarray:
        c = self.lay.counts
        covered = max(int((c > 0).sum()), 1)
        return np.array([(c == 1).sum(), (c == 2).sum(), (c >= 3).sum()]) / covered


def distances(ref: Scene, x: Scene) -> dict[str, float]:
    lay = layering(ref.lay, x.lay)
    return {
        "pcf": pcf_distance(ref.lay, x.lay),
        "swd": patch_swd(x.image, ref.image),
        "degree": abs(x.degree - ref.degree),
        "depth": float(np.abs(x.depth - ref.depth).sum()),
        "layering": 0.0 if np.isnan(lay) else 1.0 - lay,
    }


def density_error(ex: Exemplar, kinds, cut, x: KindLayout) -> float:
    """Worst |rate_out / rate_ex - 1| over whole kinds: copies centred inside the canvas, the
    exemplar's border fragments counting their share of their kind (cvt.density)."""
    owner, weight = fragment_owners(ex.elements, kinds, cut, ex.viewbox)
    worst = 0.0
    ref = _counts(ex, [(e.index, 0.0, 0.0) for e in ex.elements], ex.viewbox[2:], owner, weight)
    out = _counts(ex, x.placements, x.size, owner, weight)
    for k, n in ref.items():
        if n > 0:
            r_ex = n / (ex.viewbox[2] * ex.viewbox[3])
            worst = max(worst, abs(out.get(k, 0.0) / (x.size[0] * x.size[1]) / r_ex - 1))
    return worst


def _counts(ex: Exemplar, placed, size, owner, weight) -> dict[int, float]:
    if not placed:
        return {}
    b = np.stack([ex.elements[e].bbox + [dx, dy, dx, dy] for e, dx, dy in placed])
    vx, vy = ex.viewbox[:2]
    return kind_counts(np.array([e for e, _, _ in placed]), (b[:, :2] + b[:, 2:]) / 2, owner,
                       weight, (vx, vy, vx + size[0], vy + size[1]))


def integrity(cut: np.ndarray, x: KindLayout) -> float:
    """Share of placed elements that are whole and on the canvas."""
    if not x.placements:
        return 1.0
    b = np.stack([x.exemplar.elements[e].bbox + [dx, dy, dx, dy] for e, dx, dy in x.placements])
    (x0, y0), (w, h) = x.origin, x.size
    eps = 1e-4 * max(w, h)
    off = (b[:, 2] <= x0) | (b[:, 0] >= x0 + w) | (b[:, 3] <= y0) | (b[:, 1] >= y0 + h)
    border = ((b[:, 0] <= x0 + eps) | (b[:, 1] <= y0 + eps) | (b[:, 2] >= x0 + w - eps)
              | (b[:, 3] >= y0 + h - eps))
    frag = cut[[e for e, _, _ in x.placements]] & ~border
    return float(1 - (off | frag).mean())


def pair_rates(x: KindLayout, cut: np.ndarray, hosts=None,
               tileable: bool = False) -> dict[tuple[int, int], float]:
    """Share of companion-kind elements touching (boxes sharing >= a tenth of the smaller) an
    element of their host kind, per (companion, host); ``hosts`` picks the pairs (default:
    those with a share >= 50 %). ``tileable``: the output is a tile, so pairs are counted as
    tiled (one copy of each element, the one centred on the canvas; touches across the seam
    count)."""
    if not x.placements:
        return {}
    b = np.stack([x.exemplar.elements[e].bbox + [dx, dy, dx, dy] for e, dx, dy in x.placements])
    kk = np.array([x.kind_ids[e] for e, _, _ in x.placements])
    ok = ~cut[[e for e, _, _ in x.placements]]
    torus = None
    if tileable:
        (x0, y0), (w, h) = x.origin, x.size
        torus = Torus.of((x0, y0, x0 + w, y0 + h))
        c = (b[:, :2] + b[:, 2:]) / 2
        ok &= (c[:, 0] >= x0) & (c[:, 0] < x0 + w) & (c[:, 1] >= y0) & (c[:, 1] < y0 + h)
    on = touches(b, torus=torus)
    rates = {}
    for c in np.unique(kk[ok]):
        for h in np.unique(kk[ok]):
            if c == h:
                continue
            sel = ok & (kk == c)
            r = float(on[np.ix_(sel, ok & (kk == h))].any(1).mean())
            if hosts is None and r >= 0.5 or hosts is not None and (c, h) in hosts:
                rates[(int(c), int(h))] = r
    return rates


def references(ex: Exemplar, size, seed: int = 0) -> tuple[list, list]:
    """R1: random placement at the exemplar's density; R2: the exemplar tiled 2 x 2."""
    from cvt.baselines import random_placement

    r1 = [(p.element, p.dx, p.dy) for p in random_placement(ex, size, seed).placements]
    w, h = ex.viewbox[2:]
    r2 = [(e.index, i * w, j * h) for i in range(2) for j in range(2) for e in ex.elements]
    return r1, r2


def svg_of(ex: Exemplar, placed, size) -> str:
    from cvt.background import backdrop_nodes

    vx, vy = ex.viewbox[:2]
    return to_svg(ex, placed, size, backdrop_nodes(ex, (vx, vy, vx + size[0], vy + size[1])))


def judge(ex: Exemplar, out_svg: str, size, seed: int = 0, tileable: bool = False) -> dict:
    """Distances of output, R1 and R2 to the exemplar, verdicts and the extra checks
    (``tileable``: companion pairs counted as tiled, :func:`pair_rates`)."""
    kinds = element_kinds(ex.elements, cut := cut_mask(ex.elements, ex.viewbox))
    scale = PIXELS / ex.viewbox[2]
    w, h = ex.viewbox[2:]
    ref = Scene(svg_of(ex, [(e.index, 0.0, 0.0) for e in ex.elements], (w, h)),
                layout(ex, kinds, [(e.index, 0.0, 0.0) for e in ex.elements], (w, h), scale),
                scale)
    r1, r2 = references(ex, size, seed)
    scenes = {"out": Scene(out_svg, layout(ex, kinds, placements_of(out_svg, ex), size, scale),
                           scale)}
    for name, placed in (("R1", r1), ("R2", r2)):
        scenes[name] = Scene(svg_of(ex, placed, size), layout(ex, kinds, placed, size, scale),
                             scale)
    d = {name: distances(ref, s) for name, s in scenes.items()}
    verdict = {}
    for m in PASS_METRICS:
        a, b, o = d["R1"][m], d["R2"][m], d["out"][m]
        verdict[m] = bool(o <= (a + b) / 2 + 1e-9) if a > b else bool(o <= b + 1e-9)
    ex_pairs = pair_rates(ref.lay, cut)
    out_pairs = pair_rates(scenes["out"].lay, cut, set(ex_pairs), tileable)
    kept = min((out_pairs.get(p, 0.0) / r for p, r in ex_pairs.items()), default=float("nan"))
    lay = scenes["out"].lay
    tied = [m for m in PASS_METRICS if d["R1"][m] <= d["R2"][m]]
    return {"d": d, "verdict": verdict, "pass": all(verdict.values()), "tied": tied,
            "density": density_error(ex, kinds, cut, lay), "integrity": integrity(cut, lay),
            "pairs": kept, "elements": len(lay.placements)}
