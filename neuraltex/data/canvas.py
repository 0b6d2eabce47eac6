"""A painter's canvas that renders anti-aliased textons and tracks instance ownership.

Textons come as a batch of parameter arrays in back-to-front order. Their coverage and
colour are computed at once on equal-sized windows around each centre, shape (K, h, w),
then composited one by one. Coverage is analytic: ``alpha = clip(0.5 - sdf / edge, 0, 1)``
with ``edge`` one pixel (wider for soft textons). The instance mask is "dominant
coverage": each pixel belongs to the layer with the largest visible weight
``alpha_k * prod_{j above k}(1 - alpha_j)``. Adding a layer scales all earlier weights by
the same factor, so the arg-max is kept exactly with one running (weight, id) per pixel.
"""

from __future__ import annotations

import numpy as np

from neuraltex.data.shapes import sdf

# How far each shape reaches from its centre, in units of its larger semi-axis.
_REACH = {"box": 1.42, "blob": 1.35, "capsule": 1.05, "leaf": 1.05}


class Canvas:
    """An RGB image plus an (H, W) int32 id map. Background id is 0.

    The image is kept as colour planes (3, H, W): broadcasting a coverage map over a
    short trailing colour axis is several times slower in numpy. ``rgb`` gives (H, W, 3).
    Coordinates are normalized: short side S = 1, pixel (i, j) centre at
    ((j + 0.5) / S, (i + 0.5) / S).
    """

    def __init__(self, background: np.ndarray):
        if background.ndim != 3 or background.shape[2] != 3:
            raise ValueError(f"background must be (H, W, 3), got {background.shape}")
        self.h, self.w = background.shape[:2]
        self.s = min(self.h, self.w)
        self.px = 1.0 / self.s
        self.planes = np.ascontiguousarray(background.transpose(2, 0, 1), np.float32)  # (3, H, W)
        self.ids = np.zeros((self.h, self.w), np.int32)
        self.weight = np.ones((self.h, self.w), np.float32)
        self.next_id = 1

    @property
    def rgb(self) -> np.ndarray:
        """The image, (H, W, 3) float32 (a copy)."""
        return np.ascontiguousarray(self.planes.transpose(1, 2, 0))

    @property
    def extent(self) -> tuple[float, float]:
        return self.w / self.s, self.h / self.s

    def paint(self, t: dict, fields: dict | None = None, chunk: int = 8) -> None:
        """Render a batch of K textons (see :func:`texton_layers`), back to front.

        ``fields`` maps names to (H, W) global fields (inner noise, speckles). Textons are
        rendered in chunks of similar window size, then composited in depth order.
        """
        k = len(t["cx"])
        ids = self.next_id + np.arange(k)
        self.next_id += k
        if k == 0:
            return
        hx, hy = _half_extents(t, k)
        hx = np.ceil(hx * self.s).astype(np.int64) + 2  # (K,) half window, px
        hy = np.ceil(hy * self.s).astype(np.int64) + 2
        x0 = np.floor(t["cx"] * self.s).astype(np.int64) - hx  # (K,) window origins
        y0 = np.floor(t["cy"] * self.s).astype(np.int64) - hy
        visible = (x0 < self.w) & (x0 + 2 * hx > 0) & (y0 < self.h) & (y0 + 2 * hy > 0)
        order = np.flatnonzero(visible)
        order = order[np.argsort((hx * hy)[order], kind="stable")]
        layers = {}
        for start in range(0, len(order), chunk):
            sel = order[start:start + chunk]
            layers.update(self._layers(t, k, sel, int(2 * hx[sel].max()), int(2 * hy[sel].max()),
                                       x0, y0, fields))
        for i in sorted(layers):
            alpha, color, shadow = layers[i]
            win = self._window(int(y0[i]), int(x0[i]), alpha.shape)
            if win is None:
                continue
            (sy, sx), (wy, wx) = win
            if shadow is not None:
                self._composite(sy, sx, shadow[wy, wx], np.float32(0.0), None)
            self._composite(sy, sx, alpha[wy, wx], color[:, wy, wx], int(ids[i]))

    def _layers(self, t, k, sel, side_x, side_y, x0, y0, fields) -> dict:
        """Layers of textons ``sel`` on (side_y, side_x) windows.

        Returns {texton index: (alpha (h, w), colour (3, h, w), shadow alpha or None)}.
        """
        sub = {n: (v[sel] if isinstance(v, np.ndarray) and v.shape[:1] == (k,) else v)
               for n, v in t.items()}
        X = ((x0[sel, None] + np.arange(side_x) + 0.5) * self.px)[:, None, :].astype(np.float32)
        Y = ((y0[sel, None] + np.arange(side_y) + 0.5) * self.px)[:, :, None].astype(np.float32)
        local = None
        if fields:
            rows = np.clip(y0[sel, None] + np.arange(side_y), 0, self.h - 1)[:, :, None]
            cols = np.clip(x0[sel, None] + np.arange(side_x), 0, self.w - 1)[:, None, :]
            local = {n: f[rows, cols] for n, f in fields.items()}  # (k', side_y, side_x)
        alpha, color = texton_layers(X, Y, sub, self.px, local)
        shadow = [None] * len(sel)
        if "shadow" in t:
            sx, sy, strength = t["shadow"]
            moved = dict(sub, cx=sub["cx"] + sx, cy=sub["cy"] + sy,
                         soft=np.asarray(sub.get("soft", 0.0)) + 0.02)
            shadow = texton_layers(X, Y, moved, self.px, None, shape_only=True)[0] * strength
        return {int(i): (alpha[j], color[j], shadow[j]) for j, i in enumerate(sel)}

    def _window(self, y0: int, x0: int, shape: tuple[int, int]):
        """Canvas slices and matching window slices for a window at (y0, x0), clipped."""
        cy0, cx0 = max(y0, 0), max(x0, 0)
        cy1, cx1 = min(y0 + shape[0], self.h), min(x0 + shape[1], self.w)
        if cy0 >= cy1 or cx0 >= cx1:
            return None
        return ((slice(cy0, cy1), slice(cx0, cx1)),
                (slice(cy0 - y0, cy1 - y0), slice(cx0 - x0, cx1 - x0)))

    def _composite(self, sy: slice, sx: slice, alpha: np.ndarray, color: np.ndarray,
                   owner: int | None) -> None:
        rgb = self.planes[:, sy, sx]  # (3, h, w) view: updated in place
        rgb += (color - rgb) * alpha
        if owner is None:  # shadows darken what is below without taking it over
            return
        weight = self.weight[sy, sx]
        weight *= 1.0 - alpha
        take = alpha > weight
        np.maximum(weight, alpha, out=weight)
        np.copyto(self.ids[sy, sx], owner, where=take)


def _half_extents(t: dict, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Half width and height (normalized units) of each texton's rotated bounding box."""
    r = np.broadcast_to(np.asarray(t["r"], np.float64), (k,))
    aspect = np.broadcast_to(np.asarray(t.get("aspect", 1.0), np.float64), (k,))
    reach = max(_REACH.get(n, 1.0) for n in _kinds(t))
    au, av = r * aspect * reach, r / aspect * reach  # local semi-axes
    if not isinstance(t["kind"], str) or t["kind"] in ("capsule", "leaf"):
        # thin shapes: the v extent is the shape's half-width (leaves/capsules only)
        thin = np.broadcast_to(np.asarray(t.get("width", 1.0), np.float64), (k,))
        if not isinstance(t["kind"], str):
            thin = np.where(np.isin(t["kind"], ("capsule", "leaf")), thin, 1.0)
        av = av * thin
    angle = np.broadcast_to(np.asarray(t.get("angle", 0.0), np.float64), (k,))
    c, s = np.abs(np.cos(angle)), np.abs(np.sin(angle))
    pad = np.broadcast_to(np.asarray(t.get("soft", 0.0), np.float64), (k,)).copy()
    if "shadow" in t:
        pad += float(np.hypot(*t["shadow"][:2])) + 0.02
    return np.hypot(au * c, av * s) + pad, np.hypot(au * s, av * c) + pad


def _kinds(t: dict) -> list[str]:
    kind = t["kind"]
    return [kind] if isinstance(kind, str) else sorted(set(kind.tolist()))


def _col(v, k: int) -> np.ndarray:
    """A per-texton parameter as (K, 1, 1) float32; a scalar stays a scalar."""
    a = np.asarray(v, np.float32)
    return a.reshape(k, 1, 1) if a.ndim else a


def texton_layers(X: np.ndarray, Y: np.ndarray, t: dict, px: float, fields: dict | None,
                  shape_only: bool = False):
    """Coverage and colour of K textons on their windows.

    Shape: ``X`` (K, 1, w), ``Y`` (K, h, 1) normalized coords -> alpha (K, h, w),
    colour (K, 3, h, w). Keys of ``t`` (arrays with K rows, or scalars): cx, cy, r, kind
    (str, or (K,) str array), color (K, 3). Optional: angle, aspect, soft,
    n/star/corner/width/wobble (shape, see :func:`shapes.sdf`), dome, grad (K, 2),
    color2 (K, 3) with core (two-tone core radius) or stripes (K, 4: freq, amp, angle,
    phase), noise / speckle (amplitudes of ``fields``), outline (K, 2: width, darkness),
    vein (K, 2: width, darkness).
    """
    k = len(t["cx"])
    angle = _col(t.get("angle", 0.0), k)
    aspect, r = _col(t.get("aspect", 1.0), k), _col(t["r"], k)
    c, s = np.cos(angle), np.sin(angle)
    dx, dy = X - _col(t["cx"], k), Y - _col(t["cy"], k)
    ru, rv = r * aspect, r / aspect
    u = (dx * c + dy * s) / ru  # (K, h, w) local frame, shape radius ~1
    v = (-dx * s + dy * c) / rv
    scale = np.minimum(ru, rv)
    kinds = _kinds(t)
    d = sdf(kinds[0], u, v, t)
    for name in kinds[1:]:
        d = np.where((t["kind"] == name)[:, None, None], sdf(name, u, v, t), d)
    d = d * scale  # normalized image units
    edge = np.maximum(_col(t.get("soft", 0.0), k), px)
    alpha = np.clip(0.5 - d / edge, 0.0, 1.0).astype(np.float32)
    if shape_only:
        return alpha, None
    shade = np.float32(1.0)
    if "dome" in t:  # brighter centre, darker rim
        shade = shade - _col(t["dome"], k) * np.minimum(u * u + v * v, 1.5)
    if "grad" in t:  # linear lighting across the texton
        g = np.asarray(t["grad"], np.float32)
        shade = shade + g[:, 0, None, None] * u + g[:, 1, None, None] * v
    color = np.asarray(t["color"], np.float32)[:, :, None, None]  # (K, 3, 1, 1)
    if "core" in t:  # two-tone: an inner core of a second colour
        core = np.clip(0.5 - (np.sqrt(u * u + v * v) - _col(t["core"], k)) * scale / px, 0, 1)
        color = color + core[:, None] * (_rgb(t["color2"]) - color)
    if "stripes" in t:
        st = np.asarray(t["stripes"], np.float32)[:, :, None, None]  # (K, 4, 1, 1)
        w = u * np.cos(st[:, 2]) + v * np.sin(st[:, 2])
        band = np.clip(2.0 * np.sin(np.pi * st[:, 0] * w + st[:, 3]), -1.0, 1.0) * 0.5 + 0.5
        color = color + (st[:, 1] * band)[:, None] * (_rgb(t["color2"]) - color)
    if np.ndim(shade):
        color = color * shade[:, None]
    for name in ("noise", "speckle"):
        if fields is not None and name in t:
            color = color + (_col(t[name], k) * fields[name])[:, None]
    if "outline" in t:  # a dark band just inside the boundary
        o = np.asarray(t["outline"], np.float32)[:, :, None, None]
        band = np.clip(0.5 + (d + o[:, 0]) / px, 0.0, 1.0)
        color = color * (1.0 - o[:, 1] * band)[:, None]
    if "vein" in t:  # a midrib along the long axis
        o = np.asarray(t["vein"], np.float32)[:, :, None, None]
        band = np.clip(0.5 - (np.abs(v) * rv - o[:, 0]) / px, 0.0, 1.0) * (np.abs(u) < 0.85)
        color = color * (1.0 - o[:, 1] * band)[:, None]
    shape = (alpha.shape[0], 3) + alpha.shape[1:]
    return alpha, np.broadcast_to(color, shape).astype(np.float32)


def _rgb(colors) -> np.ndarray:
    """(K, 3) colours as (K, 3, 1, 1) float32."""
    return np.asarray(colors, np.float32)[:, :, None, None]
