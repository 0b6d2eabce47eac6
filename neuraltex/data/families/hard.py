"""Hard families: what colour-based classical segmentation gets wrong.

Inner texture and shading (textured), soft low-contrast boundaries under a lighting
gradient (soft), same-coloured overlapping leaves told apart by outlines and shadows
(leaves), overlapping fish scales separated only by shading (scales), and elongated
overlapping strokes (strokes: a deliberate hard case, seed 003 section 4.6).
"""

from __future__ import annotations

import numpy as np

from neuraltex.data.canvas import Canvas
from neuraltex.data.families.common import (
    inner_fields,
    jittered_grid,
    lighting,
    noisy_background,
    pick_colors,
    sensor_noise,
    uniform,
)
from neuraltex.data.palette import background_color, palette


def _finish(rng, canvas, light, noise):
    image = lighting(rng, canvas.rgb, light)
    return sensor_noise(rng, image, noise)


def _wobble(rng, k: int, amp: tuple[float, float], freqs: tuple[int, ...]) -> np.ndarray:
    """Radial bumps for blob outlines. Shape: (k, len(freqs), 3) amplitude, frequency, phase."""
    m = len(freqs)
    return np.stack([rng.uniform(*amp, (k, m)), np.broadcast_to(np.array(freqs), (k, m)),
                     rng.uniform(0, 2 * np.pi, (k, m))], -1)


def textured(rng, h, w):
    """Blobs filled with noise, stripes or speckles, dome-shaded, on a textured background."""
    cell = uniform(rng, 0.12, 0.2)
    bg = palette(rng, 1, value=(0.3, 0.7))[0]
    canvas = Canvas(noisy_background(rng, h, w, bg, uniform(rng, 0.08, 0.15), 12.0))
    fields = inner_fields(rng, h, w, uniform(rng, 15, 35), uniform(rng, 25, 45))
    # Texton colours sit a modest step away from the background, which is as textured
    # as the textons: colour alone does not separate them.
    contrast = uniform(rng, 0.12, 0.25)
    steps = rng.normal(0, 1, (2, 3))
    steps = contrast * np.sqrt(3) * steps / np.linalg.norm(steps, axis=1, keepdims=True)
    pal = np.clip(bg[None] + steps, 0, 1).astype(np.float32)
    texture = ("noise", "stripes", "speckle")[int(rng.integers(3))]
    centres = jittered_grid(rng, canvas.extent, cell, uniform(rng, 0.5, 1.0), 0.95)
    rng.shuffle(centres)
    k = len(centres)  # dense: neighbours touch and overlap
    t = dict(kind="blob", cx=centres[:, 0], cy=centres[:, 1], r=cell * rng.uniform(0.42, 0.62, k),
             aspect=rng.uniform(1.0, 1.4, k), angle=rng.uniform(0, np.pi, k),
             wobble=_wobble(rng, k, (0.03, 0.1), (2, 3, 5)),
             color=pick_colors(rng, pal, 0.04, k), color2=pick_colors(rng, bg[None], 0.05, k),
             dome=rng.uniform(0.2, 0.45, k), grad=rng.normal(0, 0.12, (k, 2)))
    if texture == "stripes":
        t["stripes"] = np.stack([rng.uniform(3, 6, k), rng.uniform(0.4, 0.7, k),
                                 rng.uniform(0, np.pi, k), rng.uniform(0, 6.3, k)], 1)
    else:
        t[texture] = rng.uniform(0.2, 0.35, k)
    canvas.paint(t, fields)
    image = _finish(rng, canvas, uniform(rng, 0.15, 0.35), 0.01)
    return image, canvas.ids, dict(cell=cell, texture=texture, contrast=contrast)


def soft(rng, h, w):
    """Blurred-edge, low-contrast blobs on an fBm background under a lighting gradient."""
    cell = uniform(rng, 0.12, 0.2)
    bg = palette(rng, 1, value=(0.35, 0.7), saturation=(0.1, 0.6))[0]
    canvas = Canvas(noisy_background(rng, h, w, bg, uniform(rng, 0.04, 0.08), 6.0))
    contrast = uniform(rng, 0.07, 0.14)
    direction = rng.normal(0, 1, 3)
    direction = (np.sign(direction.sum()) or 1.0) * direction / np.linalg.norm(direction)
    centres = jittered_grid(rng, canvas.extent, cell, uniform(rng, 0.5, 1.0), 0.85)
    rng.shuffle(centres)
    k = len(centres)
    gain = contrast * np.sqrt(3) * rng.uniform(0.7, 1.3, k)
    canvas.paint(dict(kind="blob", cx=centres[:, 0], cy=centres[:, 1],
                      r=cell * rng.uniform(0.3, 0.48, k), aspect=rng.uniform(1.0, 1.5, k),
                      angle=rng.uniform(0, np.pi, k), soft=cell * rng.uniform(0.12, 0.25, k),
                      wobble=_wobble(rng, k, (0.02, 0.08), (3,)),
                      color=np.clip(bg + gain[:, None] * direction, 0, 1).astype(np.float32),
                      dome=rng.uniform(0.0, 0.15, k)))
    image = _finish(rng, canvas, uniform(rng, 0.25, 0.45), 0.02)
    return image, canvas.ids, dict(cell=cell, contrast=contrast)


def leaves(rng, h, w):
    """Same-coloured, densely overlapping leaves; only thin outlines, veins and shadows differ."""
    cell = uniform(rng, 0.1, 0.16)
    base = palette(rng, 1, value=(0.35, 0.8))
    canvas = Canvas(noisy_background(rng, h, w, background_color(rng, dark=True), 0.03, 8.0))
    direction, spread = uniform(rng, 0, np.pi), uniform(rng, 0.3, np.pi)
    shadow = (uniform(rng, 0.005, 0.012), uniform(rng, 0.005, 0.012), uniform(rng, 0.25, 0.45))
    centres = jittered_grid(rng, canvas.extent, cell, 1.0, 1.0)
    rng.shuffle(centres)
    k = len(centres)
    canvas.paint(dict(kind="leaf", cx=centres[:, 0], cy=centres[:, 1],
                      r=cell * rng.uniform(0.8, 1.2, k), width=rng.uniform(0.3, 0.45, k),
                      angle=direction + rng.uniform(-spread, spread, k),
                      color=pick_colors(rng, base, 0.02, k), grad=rng.normal(0, 0.08, (k, 2)),
                      outline=np.stack([np.full(k, 0.004), rng.uniform(0.15, 0.35, k)], 1),
                      vein=np.stack([np.full(k, 0.003), rng.uniform(0.1, 0.25, k)], 1),
                      shadow=shadow))
    image = _finish(rng, canvas, uniform(rng, 0.1, 0.3), 0.01)
    return image, canvas.ids, dict(cell=cell, spread=spread)


def scales(rng, h, w):
    """Overlapping fish scales in staggered rows, one colour, told apart by shading only."""
    cell = uniform(rng, 0.1, 0.16)
    base = palette(rng, 1, value=(0.4, 0.85))
    canvas = Canvas(np.broadcast_to(base[0], (h, w, 3)).astype(np.float32))
    extent = canvas.extent
    row_step = cell * uniform(rng, 0.45, 0.6)
    n_rows, n_cols = int(extent[1] / row_step) + 3, int(extent[0] / cell) + 3
    rows, cols = np.meshgrid(np.arange(-1, n_rows), np.arange(-1, n_cols), indexing="ij")
    rows, cols = rows.ravel(), cols.ravel()  # row-major: lower rows painted last, on top
    k = len(rows)
    grad, dome = uniform(rng, 0.25, 0.45), uniform(rng, 0.0, 0.2)
    canvas.paint(dict(kind="ellipse", cx=((cols + 0.5 + 0.5 * (rows % 2)) * cell),
                      cy=rows * row_step, r=np.full(k, cell * 0.62),
                      color=pick_colors(rng, base, 0.02, k),
                      grad=np.tile([0.0, grad], (k, 1)), dome=dome,
                      outline=np.tile([0.003, 0.1], (k, 1))))
    image = _finish(rng, canvas, uniform(rng, 0.1, 0.3), 0.01)
    return image, canvas.ids, dict(cell=cell, row_step=row_step)


def strokes(rng, h, w):
    """Long overlapping strokes (grass, hair) around one orientation: elongated hard case."""
    cell = uniform(rng, 0.08, 0.12)
    pal = palette(rng, 2, value=(0.3, 0.8))
    pal[1] = np.clip(pal[0] + rng.normal(0, 0.08, 3), 0, 1)
    canvas = Canvas(noisy_background(rng, h, w, background_color(rng), 0.04, 6.0))
    direction, spread = uniform(rng, 0, np.pi), uniform(rng, 0.1, 0.4)
    centres = jittered_grid(rng, canvas.extent, cell, 1.0, 0.9)
    rng.shuffle(centres)
    k = len(centres)
    canvas.paint(dict(kind="capsule", cx=centres[:, 0], cy=centres[:, 1],
                      r=cell * rng.uniform(1.0, 1.6, k), width=rng.uniform(0.1, 0.16, k),
                      angle=direction + rng.normal(0, spread, k),
                      color=pick_colors(rng, pal, 0.03, k),
                      grad=np.stack([rng.uniform(-0.3, 0.3, k), np.zeros(k)], 1),
                      outline=np.tile([0.003, 0.15], (k, 1))))
    image = _finish(rng, canvas, uniform(rng, 0.1, 0.3), 0.01)
    return image, canvas.ids, dict(cell=cell, spread=spread)
