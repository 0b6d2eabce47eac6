"""Shapes scattered over a background: flat colours (easy) or two-tone (hard).

Each family is ``render(rng, h, w) -> (image (H, W, 3), ids (H, W), params)``; the
ids are raw painter ids (0 = background) that the generator relabels to 1..K.
Per-texton parameters are drawn as arrays, one row per texton, in depth order.
"""

from __future__ import annotations

import numpy as np

from neuraltex.data.canvas import Canvas
from neuraltex.data.families.common import (
    jittered_grid,
    noisy_background,
    pick_colors,
    sensor_noise,
    uniform,
)
from neuraltex.data.palette import background_color, palette


def _scatter(rng, h, w, cell, jitter, presence, make_textons, bg_noise=0.0, bg_freq=4.0,
             dark=None):
    bg = background_color(rng, dark)
    canvas = Canvas(noisy_background(rng, h, w, bg, bg_noise, bg_freq))
    centres = jittered_grid(rng, canvas.extent, cell, jitter, presence)
    rng.shuffle(centres)  # random depth order
    t = make_textons(len(centres))
    canvas.paint(dict(t, cx=centres[:, 0], cy=centres[:, 1]))
    image = sensor_noise(rng, canvas.rgb, 0.005)
    return image, canvas.ids, dict(cell=cell, jitter=jitter, presence=presence,
                                   bg_noise=bg_noise)


def discs(rng, h, w):
    """Discs and ellipses of varied size, flat colours around a small palette."""
    cell, jitter, presence = uniform(rng, 0.1, 0.2), uniform(rng, 0.3, 1.0), uniform(rng, 0.6, 1)
    pal, spread = palette(rng, int(rng.integers(1, 4))), uniform(rng, 0.0, 0.05)
    max_aspect = uniform(rng, 1.0, 1.8)

    def textons(k):
        return dict(kind="ellipse", r=cell * rng.uniform(0.18, 0.42, k),
                    aspect=rng.uniform(1.0, max_aspect, k), angle=rng.uniform(0, np.pi, k),
                    color=pick_colors(rng, pal, spread, k))

    return _scatter(rng, h, w, cell, jitter, presence, textons, uniform(rng, 0, 0.03))


def polygons(rng, h, w):
    """Rotated regular polygons or stars."""
    cell, jitter = uniform(rng, 0.11, 0.2), uniform(rng, 0.2, 0.9)
    star = bool(rng.uniform() < 0.5)
    n = int(rng.integers(4, 8)) if star else int(rng.integers(3, 9))
    depth = uniform(rng, 0.3, 0.6)
    pal, spread = palette(rng, int(rng.integers(1, 4))), uniform(rng, 0.0, 0.05)

    def textons(k):
        return dict(kind="star" if star else "polygon", n=n, star=depth,
                    r=cell * rng.uniform(0.28, 0.45, k), angle=rng.uniform(0, 2 * np.pi, k),
                    color=pick_colors(rng, pal, spread, k))

    return _scatter(rng, h, w, cell, jitter, uniform(rng, 0.7, 1.0), textons,
                    uniform(rng, 0, 0.03))


def grid(rng, h, w):
    """A (nearly) regular grid of one shape: the regular end of the spectrum."""
    cell = uniform(rng, 0.1, 0.18)
    kind = ("box", "ellipse", "polygon")[int(rng.integers(3))]
    size, angle = uniform(rng, 0.28, 0.42), uniform(rng, 0, np.pi)
    n, corner = int(rng.integers(3, 7)), uniform(rng, 0.05, 0.4)
    pal = palette(rng, int(rng.integers(1, 3)))

    def textons(k):
        return dict(kind=kind, n=n, corner=corner, r=cell * size * rng.uniform(0.95, 1.05, k),
                    angle=angle + rng.uniform(-0.05, 0.05, k),
                    color=pick_colors(rng, pal, 0.02, k))

    return _scatter(rng, h, w, cell, uniform(rng, 0.0, 0.12), 1.0, textons)


def dots(rng, h, w):
    """Small, well-contrasted dots on a noisy (fBm) background."""
    cell, dark = uniform(rng, 0.07, 0.12), bool(rng.uniform() < 0.5)
    base = palette(rng, 1, value=(0.85, 1.0) if dark else (0.15, 0.35))

    def textons(k):
        return dict(kind="ellipse", r=cell * rng.uniform(0.18, 0.32, k),
                    aspect=rng.uniform(1.0, 1.3, k), angle=rng.uniform(0, np.pi, k),
                    color=pick_colors(rng, base, 0.04, k))

    return _scatter(rng, h, w, cell, uniform(rng, 0.5, 1.0), uniform(rng, 0.6, 1.0), textons,
                    bg_noise=uniform(rng, 0.08, 0.15), bg_freq=uniform(rng, 4, 10), dark=dark)


def mixture(rng, h, w):
    """Two texton kinds mixed: large rounded shapes and small stars, two palettes."""
    cell = uniform(rng, 0.1, 0.18)
    big_kind = ("ellipse", "box")[int(rng.integers(2))]
    pal = palette(rng, 2)
    share = uniform(rng, 0.3, 0.7)

    def textons(k):
        big = rng.uniform(size=k) < share
        return dict(kind=np.where(big, big_kind, "star"), corner=0.3, n=5, star=0.5,
                    r=cell * np.where(big, rng.uniform(0.35, 0.48, k), rng.uniform(0.2, 0.3, k)),
                    aspect=np.where(big, rng.uniform(1.0, 1.4, k), 1.0),
                    angle=rng.uniform(0, 2 * np.pi, k),
                    color=np.where(big[:, None], pick_colors(rng, pal[:1], 0.03, k),
                                   pick_colors(rng, pal[1:], 0.03, k)))

    return _scatter(rng, h, w, cell, uniform(rng, 0.4, 1.0), uniform(rng, 0.7, 1.0), textons,
                    uniform(rng, 0, 0.03))


def two_tone(rng, h, w):
    """HARD: textons with inner structure, a core of a second colour or bold stripes inside.

    Flat colours, but every texton is two colour regions: colour clustering and graph
    segmentation split it in two (measured: the baselines score like on hard families).
    """
    cell, striped = uniform(rng, 0.12, 0.2), bool(rng.uniform() < 0.5)
    pal = palette(rng, 2)
    core, freq, sang = uniform(rng, 0.35, 0.6), uniform(rng, 1.5, 3.0), uniform(rng, 0, np.pi)

    def textons(k):
        t = dict(kind="ellipse", r=cell * rng.uniform(0.3, 0.45, k),
                 aspect=rng.uniform(1, 1.3, k), angle=rng.uniform(0, np.pi, k),
                 color=pick_colors(rng, pal[:1], 0.03, k),
                 color2=pick_colors(rng, pal[1:], 0.03, k))
        if striped:
            t["stripes"] = np.stack([np.full(k, freq), np.ones(k), np.full(k, sang),
                                     rng.uniform(0, 2 * np.pi, k)], 1)
        else:
            t["core"] = core
        return t

    return _scatter(rng, h, w, cell, uniform(rng, 0.2, 0.8), uniform(rng, 0.7, 1.0), textons)
