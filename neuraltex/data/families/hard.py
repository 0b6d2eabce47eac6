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
    sensor_noise,
    uniform,
)
from neuraltex.data.palette import background_color, near, palette


def _finish(rng, canvas, light, noise):
    image = lighting(rng, canvas.rgb, light)
    return sensor_noise(rng, image, noise)


def textured(rng, h, w):
    """Blobs filled with noise, stripes or speckles, dome-shaded, on a textured background."""
    cell = uniform(rng, 0.12, 0.2)
    bg = palette(rng, 1, value=(0.3, 0.7))[0]
    canvas = Canvas(noisy_background(rng, h, w, bg, uniform(rng, 0.08, 0.15), 12.0))
    fields = inner_fields(rng, h, w, uniform(rng, 15, 35), uniform(rng, 25, 45))
    pal = palette(rng, 2, value=(0.3, 0.9))
    texture = ("noise", "stripes", "speckle")[int(rng.integers(3))]
    centres = jittered_grid(rng, canvas.extent, cell, uniform(rng, 0.5, 1.0), 0.9)
    rng.shuffle(centres)
    for cx, cy in centres:
        t = dict(kind="blob", cx=float(cx), cy=float(cy), r=cell * uniform(rng, 0.35, 0.55),
                 aspect=uniform(rng, 1.0, 1.4), angle=uniform(rng, 0, np.pi),
                 wobble=[(uniform(rng, 0.03, 0.1), k, uniform(rng, 0, 6.3)) for k in (2, 3, 5)],
                 color=near(rng, pal[rng.integers(2)], 0.04)[0], color2=near(rng, bg, 0.05)[0],
                 dome=uniform(rng, 0.2, 0.45), grad=rng.normal(0, 0.12, 2))
        if texture == "stripes":
            t["stripes"] = (uniform(rng, 3, 6), uniform(rng, 0.4, 0.7), uniform(rng, 0, np.pi),
                            uniform(rng, 0, 6.3))
        else:
            t[texture] = uniform(rng, 0.15, 0.3)
        canvas.paint(t, fields)
    image = _finish(rng, canvas, uniform(rng, 0.15, 0.35), 0.01)
    return image, canvas.ids, dict(cell=cell, texture=texture)


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
    for cx, cy in centres:
        color = np.clip(bg + contrast * direction * np.sqrt(3) * uniform(rng, 0.7, 1.3), 0, 1)
        canvas.paint(dict(kind="blob", cx=float(cx), cy=float(cy),
                          r=cell * uniform(rng, 0.3, 0.48), aspect=uniform(rng, 1.0, 1.5),
                          angle=uniform(rng, 0, np.pi), soft=cell * uniform(rng, 0.12, 0.25),
                          wobble=[(uniform(rng, 0.02, 0.08), 3, uniform(rng, 0, 6.3))],
                          color=color.astype(np.float32), dome=uniform(rng, 0.0, 0.15)))
    image = _finish(rng, canvas, uniform(rng, 0.25, 0.45), 0.02)
    return image, canvas.ids, dict(cell=cell, contrast=contrast)


def leaves(rng, h, w):
    """Same-coloured, densely overlapping leaves; only thin outlines, veins and shadows differ."""
    cell = uniform(rng, 0.1, 0.16)
    base = palette(rng, 1, value=(0.35, 0.8))[0]
    canvas = Canvas(noisy_background(rng, h, w, background_color(rng, dark=True), 0.03, 8.0))
    direction, spread = uniform(rng, 0, np.pi), uniform(rng, 0.3, np.pi)
    shadow = (uniform(rng, 0.005, 0.012), uniform(rng, 0.005, 0.012), uniform(rng, 0.25, 0.45))
    centres = jittered_grid(rng, canvas.extent, cell, 1.0, 1.0)
    rng.shuffle(centres)
    for cx, cy in centres:
        canvas.paint(dict(kind="leaf", cx=float(cx), cy=float(cy),
                          r=cell * uniform(rng, 0.8, 1.2), width=uniform(rng, 0.3, 0.45),
                          angle=direction + uniform(rng, -spread, spread),
                          color=near(rng, base, 0.02)[0], grad=rng.normal(0, 0.08, 2),
                          outline=(0.004, uniform(rng, 0.15, 0.35)), shadow=shadow,
                          vein=(0.003, uniform(rng, 0.1, 0.25))))
    image = _finish(rng, canvas, uniform(rng, 0.1, 0.3), 0.01)
    return image, canvas.ids, dict(cell=cell, spread=spread)


def scales(rng, h, w):
    """Overlapping fish scales in staggered rows, one colour, told apart by shading only."""
    cell = uniform(rng, 0.1, 0.16)
    base = palette(rng, 1, value=(0.4, 0.85))[0]
    canvas = Canvas(np.broadcast_to(base, (h, w, 3)).astype(np.float32))
    extent = canvas.extent
    row_step = cell * uniform(rng, 0.45, 0.6)
    n_rows, n_cols = int(extent[1] / row_step) + 3, int(extent[0] / cell) + 3
    grad, dome = uniform(rng, 0.25, 0.45), uniform(rng, 0.0, 0.2)
    for row in range(-1, n_rows):  # top to bottom: lower rows cover the ones above
        shift = 0.5 * cell * (row % 2)
        for col in range(-1, n_cols):
            canvas.paint(dict(kind="ellipse", cx=(col + 0.5) * cell + shift,
                              cy=row * row_step, r=cell * 0.62, color=near(rng, base, 0.02)[0],
                              grad=(0.0, grad), dome=dome, outline=(0.003, 0.1)))
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
    for cx, cy in centres:
        canvas.paint(dict(kind="capsule", cx=float(cx), cy=float(cy),
                          r=cell * uniform(rng, 1.0, 1.6), width=uniform(rng, 0.1, 0.16),
                          angle=direction + rng.normal(0, spread),
                          color=near(rng, pal[rng.integers(2)], 0.03)[0],
                          grad=(uniform(rng, -0.3, 0.3), 0.0), outline=(0.003, 0.15)))
    image = _finish(rng, canvas, uniform(rng, 0.1, 0.3), 0.01)
    return image, canvas.ids, dict(cell=cell, spread=spread)
