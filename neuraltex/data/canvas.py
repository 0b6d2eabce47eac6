"""A painter's canvas that renders anti-aliased textons and tracks instance ownership.

Textons are painted back to front, each only inside its bounding window. Coverage is
analytic: ``alpha = clip(0.5 - sdf / edge, 0, 1)`` with ``edge`` one pixel (or wider for
soft textons). The instance mask is "dominant coverage": after compositing, each pixel
belongs to the layer with the largest visible weight ``alpha_k * prod_{j above k}(1 - alpha_j)``.
All earlier weights shrink by the same factor when a layer is added, so the arg-max is
kept exactly with one running (weight, id) pair per pixel.
"""

from __future__ import annotations

import math

import numpy as np

from neuraltex.data.shapes import sdf

# How far each shape reaches from its centre, in units of its larger semi-axis.
_REACH = {"box": 1.42, "blob": 1.35}


class Canvas:
    """An (H, W, 3) float32 image plus an (H, W) int32 id map. Background id is 0.

    Coordinates are normalized: short side S = 1, pixel (i, j) centre at
    ((j + 0.5) / S, (i + 0.5) / S).
    """

    def __init__(self, background: np.ndarray):
        if background.ndim != 3 or background.shape[2] != 3:
            raise ValueError(f"background must be (H, W, 3), got {background.shape}")
        self.h, self.w = background.shape[:2]
        self.s = min(self.h, self.w)
        self.px = 1.0 / self.s
        self.x = ((np.arange(self.w) + 0.5) / self.s).astype(np.float32)
        self.y = ((np.arange(self.h) + 0.5) / self.s).astype(np.float32)
        self.rgb = background.astype(np.float32).copy()
        self.ids = np.zeros((self.h, self.w), np.int32)
        self.weight = np.ones((self.h, self.w), np.float32)
        self.next_id = 1

    @property
    def extent(self) -> tuple[float, float]:
        return self.w / self.s, self.h / self.s

    def window(self, cx: float, cy: float, reach: float):
        """Pixel slices and coordinates covering a disc of radius ``reach`` around (cx, cy)."""
        x0 = max(int(np.floor((cx - reach) * self.s)), 0)
        x1 = min(int(np.ceil((cx + reach) * self.s)) + 1, self.w)
        y0 = max(int(np.floor((cy - reach) * self.s)), 0)
        y1 = min(int(np.ceil((cy + reach) * self.s)) + 1, self.h)
        if x0 >= x1 or y0 >= y1:
            return None
        return (slice(y0, y1), slice(x0, x1)), self.x[None, x0:x1], self.y[y0:y1, None]

    def composite(self, win, alpha: np.ndarray, color: np.ndarray, owner: bool = True) -> None:
        """Paint ``color`` (h, w, 3) with ``alpha`` (h, w) over the window; track ownership."""
        sl = win[0]
        rgb = self.rgb[sl]  # views: updated in place
        rgb += (color - rgb) * alpha[..., None]
        if not owner:  # shadows darken what is below without taking it over
            return
        weight = self.weight[sl]
        weight *= 1.0 - alpha
        take = alpha > weight
        np.maximum(weight, alpha, out=weight)
        self.ids[sl][take] = self.next_id
        self.next_id += 1

    def paint(self, t: dict, fields: dict | None = None) -> None:
        """Render one texton described by ``t`` (see :func:`texton_layer`), with its shadow."""
        aspect = t.get("aspect", 1.0)
        reach = t["r"] * max(aspect, 1.0 / aspect) * _REACH.get(t["kind"], 1.0)
        reach += t.get("soft", 0.0) + 2 * self.px
        if "shadow" in t:
            sx, sy, strength = t["shadow"]
            win = self.window(t["cx"] + sx, t["cy"] + sy, reach + 0.02)
            if win is not None:
                shadow = dict(t, cx=t["cx"] + sx, cy=t["cy"] + sy, soft=t.get("soft", 0) + 0.02)
                alpha, _ = texton_layer(win[1], win[2], shadow, self.px, None, shape_only=True)
                self.composite(win, alpha * strength, np.zeros(3, np.float32), owner=False)
        win = self.window(t["cx"], t["cy"], reach)
        if win is None:
            self.next_id += 1
            return
        local = {k: f[win[0]] for k, f in fields.items()} if fields else None
        alpha, color = texton_layer(win[1], win[2], t, self.px, local)
        self.composite(win, alpha, color)


def texton_layer(X: np.ndarray, Y: np.ndarray, t: dict, px: float, fields: dict | None,
                 shape_only: bool = False):
    """Coverage and colour of one texton on a window.

    Shape: ``X`` (1, w), ``Y`` (h, 1) normalized coords -> alpha (h, w), colour (h, w, 3).
    Required keys of ``t``: cx, cy, r, kind, color (3,). Optional: angle, aspect, soft,
    n/star/corner/width/wobble (shape), dome, grad (2,), color2 + core (two-tone core),
    stripes (freq, amp, angle, phase) with color2, noise (amplitude of ``fields['noise']``),
    speckle (amplitude of ``fields['speckle']``), outline (width, darkness), vein (width, dark).
    """
    angle, aspect, r = t.get("angle", 0.0), t.get("aspect", 1.0), t["r"]
    c, s = math.cos(angle), math.sin(angle)
    dx, dy = X - t["cx"], Y - t["cy"]
    ru, rv = r * aspect, r / aspect
    u = (dx * c + dy * s) / ru  # (h, w) local frame, shape radius ~1
    v = (-dx * s + dy * c) / rv
    scale = min(ru, rv)
    d = sdf(t["kind"], u, v, t) * scale  # normalized image units
    edge = max(px, t.get("soft", 0.0))
    alpha = np.clip(0.5 - d / edge, 0.0, 1.0).astype(np.float32)
    if shape_only:
        return alpha, None
    shade = None
    if "dome" in t:  # brighter centre, darker rim
        shade = 1.0 - float(t["dome"]) * np.minimum(u * u + v * v, 1.5)
    if "grad" in t:  # linear lighting across the texton
        gu, gv = float(t["grad"][0]), float(t["grad"][1])
        shade = (1.0 if shade is None else shade) + gu * u + gv * v
    color = np.asarray(t["color"], np.float32)  # (3,), broadcast until it varies
    if "core" in t:  # two-tone: an inner core of a second colour
        core = np.clip(0.5 - (np.sqrt(u * u + v * v) - t["core"]) * scale / px, 0.0, 1.0)
        color = color + core[..., None] * (np.asarray(t["color2"], np.float32) - color)
    if "stripes" in t:
        freq, amp, sang, phase = t["stripes"]
        w = u * math.cos(sang) + v * math.sin(sang)
        band = np.clip(2.0 * np.sin(np.pi * freq * w + phase), -1.0, 1.0) * 0.5 + 0.5
        color = color + (amp * band)[..., None] * (np.asarray(t["color2"], np.float32) - color)
    if shade is not None:
        color = color * shade[..., None]
    if fields is not None and "noise" in t:
        color = color + t["noise"] * fields["noise"][..., None]
    if fields is not None and "speckle" in t:
        color = color + t["speckle"] * fields["speckle"][..., None]
    if "outline" in t:  # a dark band just inside the boundary
        width, dark = t["outline"]
        band = np.clip(0.5 + (d + width) / px, 0.0, 1.0)
        color = color * (1.0 - dark * band)[..., None]
    if "vein" in t:  # a midrib along the long axis
        width, dark = t["vein"]
        band = np.clip(0.5 - (np.abs(v) * rv - width) / px, 0.0, 1.0) * (np.abs(u) < 0.85)
        color = color * (1.0 - dark * band)[..., None]
    return alpha, np.broadcast_to(color, alpha.shape + (3,)).astype(np.float32, copy=False)
