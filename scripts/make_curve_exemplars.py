"""Write the shipped curve exemplars (cvt/exemplars/curves/*.svg), procedurally, seeded.

Twelve kinds of connected-stroke patterns, 200 x 200 user units each: waves, vines (tendrils
branching off stems), scribbles (crossing closed blobs), hatching, cracks (branching trees),
voronoi cells, circuit traces with pads (discrete elements beside curves), spirals, lace
(linked rings), zentangle arcs, chain links and crosshatch. Written by this script, so no
third-party licence applies (the project's MIT licence).

    python scripts/make_curve_exemplars.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "cvt" / "exemplars" / "curves"
S = 200.0


def _path(p, color, width=2.0, closed=False) -> str:
    body = " L".join(f"{x:.2f},{y:.2f}" for x, y in p)
    return (f'<path d="M{body}{" Z" if closed else ""}" fill="none" stroke="{color}" '
            f'stroke-width="{width:g}" stroke-linecap="round"/>')


def _doc(items: list[str]) -> str:
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{S:g}" height="{S:g}" '
            f'viewBox="0 0 {S:g} {S:g}">\n' + "\n".join(items) + "\n</svg>\n")


def waves(rng):
    x = np.linspace(0, S, 120)
    return [_path(np.c_[x, y0 + 7 * np.sin(x / 16 + rng.uniform(0, 6))], "#1d3557")
            for y0 in np.arange(14, S, 26)]


def _spiral(c, r0, turns, a0, sign=1, n=60):
    t = np.linspace(0, turns * 2 * np.pi, n)
    r = r0 * (1 - t / (turns * 2 * np.pi * 1.15))
    return np.c_[c[0] + r * np.cos(a0 + sign * t), c[1] + r * np.sin(a0 + sign * t)]


def vines(rng):
    items, x = [], np.linspace(0, S, 140)
    for y0 in (35, 100, 165):
        ph = rng.uniform(0, 6)
        y = y0 + 10 * np.sin(x / 22 + ph)
        items.append(_path(np.c_[x, y], "#2d6a4f", 2.5))
        for k, xi in enumerate(np.arange(rng.uniform(8, 20), S, 26)):
            yi = y0 + 10 * np.sin(xi / 22 + ph)
            side = 1 if k % 2 else -1
            c = np.array([xi + 8, yi + side * 12])
            start = np.arctan2(yi - c[1], xi - c[0])
            items.append(_path(_spiral(c, np.hypot(8, 12), 1.3, start, side), "#52b788", 1.5))
    return items


def scribbles(rng):
    items = []
    for c in np.stack(np.meshgrid([35, 100, 165], [35, 100, 165]), -1).reshape(-1, 2):
        c = c + rng.uniform(-12, 12, 2)
        t = np.linspace(0, 2 * np.pi, 90, endpoint=False)
        r = 30 + sum(rng.uniform(-6, 6) * np.cos(k * t + rng.uniform(0, 6)) for k in (2, 3, 5))
        items.append(_path(np.c_[c[0] + r * np.cos(t), c[1] + r * np.sin(t)], "#6d597a", 1.8,
                           closed=True))
    return items


def hatching(rng):
    items = []
    for cx in np.arange(20, S, 40):
        for cy in np.arange(20, S, 40):
            a = rng.uniform(0, np.pi)
            d, n = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
            for o in np.linspace(-10, 10, 5):
                c = np.array([cx, cy]) + o * n
                items.append(_path(np.r_[[c - 13 * d], [c + 13 * d]], "#222222", 1.6))
    return items


def cracks(rng):
    items = []

    def grow(p, a, depth, length):
        pts = [p]
        for _ in range(int(length)):
            a += rng.normal(0, 0.25)
            p = p + 3 * np.array([np.cos(a), np.sin(a)])
            pts.append(p)
            if depth < 3 and rng.random() < 0.06:
                grow(p, a + rng.choice([-1, 1]) * rng.uniform(0.5, 1.0), depth + 1, length * 0.6)
        items.append(_path(np.array(pts), "#5c4033", 1.6))

    for cx in (35, 100, 165):
        for cy in (35, 100, 165):
            grow(np.array([cx, cy]) + rng.uniform(-15, 15, 2), rng.uniform(0, 2 * np.pi), 0, 14)
    return items


def voronoi(rng):
    from scipy.spatial import Voronoi

    pts = rng.uniform(-40, S + 40, (60, 2))
    v = Voronoi(pts)
    items = []
    for a, b in v.ridge_vertices:
        if a >= 0 and b >= 0:
            items.append(_path(v.vertices[[a, b]], "#264653", 1.8))
    return items


def circuit(rng):
    items = []
    for _ in range(24):
        p = np.round(rng.uniform(10, 190, 2) / 10) * 10
        pts = [p]
        for _ in range(rng.integers(2, 5)):
            d = rng.choice([[1, 0], [-1, 0], [0, 1], [0, -1]])
            p = np.clip(p + np.array(d) * 10 * rng.integers(2, 6), 5, 195)
            pts.append(p)
        items.append(_path(np.array(pts, dtype=float), "#b5651d", 2.0))
        for q in (pts[0], pts[-1]):
            items.append(f'<circle cx="{q[0]:.1f}" cy="{q[1]:.1f}" r="3.5" fill="#b5651d"/>')
    return items


def spirals(rng):
    items = []
    for cx in np.arange(25, S, 50):
        for cy in np.arange(25, S, 50):
            c = np.array([cx, cy]) + rng.uniform(-6, 6, 2)
            items.append(_path(_spiral(c, 20, 2.2, rng.uniform(0, 6), rng.choice([-1, 1]), 90),
                               "#9d0208", 1.6))
    return items


def lace(rng):
    items, t = [], np.linspace(0, 2 * np.pi, 48, endpoint=False)
    for cx in np.arange(20, S, 40):
        for cy in np.arange(20, S, 40):
            items.append(_path(np.c_[cx + 11 * np.cos(t), cy + 11 * np.sin(t)], "#3a3a6a", 1.6,
                               closed=True))
            items.append(_path(np.array([[cx + 11, cy], [cx + 29, cy]]), "#3a3a6a", 1.6))
            items.append(_path(np.array([[cx, cy + 11], [cx, cy + 29]]), "#3a3a6a", 1.6))
    return items


def zentangle(rng):
    items = []
    for cx in np.arange(0, S, 50):
        for cy in np.arange(0, S, 50):
            corner = np.array([cx, cy]) + 50 * rng.integers(0, 2, 2)
            a0 = np.arctan2(cy + 25 - corner[1], cx + 25 - corner[0]) - np.pi / 4
            t = np.linspace(a0, a0 + np.pi / 2, 30)
            for r in (12, 24, 36, 48):
                items.append(_path(np.c_[corner[0] + r * np.cos(t), corner[1] + r * np.sin(t)],
                                   "#003049", 1.6))
    return items


def chain(rng):
    items, t = [], np.linspace(0, 2 * np.pi, 40, endpoint=False)
    for row, cy in enumerate(np.arange(25, S, 50)):
        for cx in np.arange(12 + 14 * (row % 2), S, 28):
            items.append(_path(np.c_[cx + 17 * np.cos(t), cy + 9 * np.sin(t)], "#6c757d", 1.8,
                               closed=True))
    return items


def crosshatch(rng):
    items = []
    for off in np.arange(-S, S, 22):
        items.append(_path(np.array([[off, 0], [off + S, S]]), "#343a40", 1.2))
        items.append(_path(np.array([[off + S, 0], [off, S]]), "#343a40", 1.2))
    return items


KINDS = {f.__name__: f for f in (waves, vines, scribbles, hatching, cracks, voronoi, circuit,
                                  spirals, lace, zentangle, chain, crosshatch)}


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    for k, (name, make) in enumerate(KINDS.items()):
        (OUT / f"{name}.svg").write_text(_doc(make(np.random.default_rng(100 + k))))
        print(f"wrote {OUT / name}.svg")


if __name__ == "__main__":
    main()
