"""Generate the shipped SVG exemplars (cvt/exemplars/*.svg) deterministically.

    python scripts/make_exemplars.py [--out cvt/exemplars]

Every shape is drawn here from simple math (no third-party artwork), so the files are ours
(MIT, like the project). Elements are top-level nodes; multi-part motifs are <g> groups.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

SIZE = 200.0


def _f(v: float) -> str:
    return f"{v:.2f}".rstrip("0").rstrip(".")


def _pts(points) -> str:
    return " ".join(f"{_f(x)},{_f(y)}" for x, y in points)


def scatter(rng, n, min_dist, margin=8.0, tries=5000):
    """Dart-throwing centers inside the tile."""
    pts = []
    for _ in range(tries):
        p = rng.uniform(margin, SIZE - margin, 2)
        if all(np.hypot(*(p - q)) >= min_dist for q in pts):
            pts.append(p)
            if len(pts) == n:
                break
    return pts


def star(cx, cy, r, k=5, inner=0.45, rot=0.0, fill="#f2c14e"):
    pts = []
    for j in range(2 * k):
        a = rot + math.pi * j / k - math.pi / 2
        rr = r if j % 2 == 0 else r * inner
        pts.append((cx + rr * math.cos(a), cy + rr * math.sin(a)))
    return f'<polygon points="{_pts(pts)}" fill="{fill}"/>'


def leaf(cx, cy, length, angle, fill="#4a9a4a"):
    w = length * 0.35
    d = (f"M {_f(-length / 2)} 0 C {_f(-length / 4)} {_f(-w)} {_f(length / 4)} {_f(-w)} "
         f"{_f(length / 2)} 0 C {_f(length / 4)} {_f(w)} {_f(-length / 4)} {_f(w)} "
         f"{_f(-length / 2)} 0 Z")
    return (f'<g transform="translate({_f(cx)},{_f(cy)}) rotate({_f(angle)})">'
            f'<path d="{d}" fill="{fill}"/>'
            f'<path d="M {_f(-length / 2)} 0 L {_f(length / 2)} 0" stroke="#2d5e2d" '
            f'stroke-width="1" fill="none"/></g>')


def flower(cx, cy, r, petals=5, rot=0.0, fill="#e86a92", center="#ffd166"):
    parts = []
    for j in range(petals):
        a = rot + 2 * math.pi * j / petals
        px, py = cx + 0.55 * r * math.cos(a), cy + 0.55 * r * math.sin(a)
        parts.append(f'<circle cx="{_f(px)}" cy="{_f(py)}" r="{_f(0.45 * r)}" fill="{fill}"/>')
    parts.append(f'<circle cx="{_f(cx)}" cy="{_f(cy)}" r="{_f(0.3 * r)}" fill="{center}"/>')
    return "<g>" + "".join(parts) + "</g>"


def heart(cx, cy, s, angle=0.0, fill="#d1495b"):
    d = ("M 0 3 C -1 2 -4 0 -4 -2 C -4 -4 -1.5 -4.5 0 -2.5 C 1.5 -4.5 4 -4 4 -2 "
         "C 4 0 1 2 0 3 Z")
    return (f'<path d="{d}" fill="{fill}" transform="translate({_f(cx)},{_f(cy)}) '
            f'rotate({_f(angle)}) scale({_f(s / 8)})"/>')


def ring(cx, cy, r, stroke="#30638e", width=2.5):
    return (f'<circle cx="{_f(cx)}" cy="{_f(cy)}" r="{_f(r)}" fill="none" stroke="{stroke}" '
            f'stroke-width="{_f(width)}"/>')


def rect(cx, cy, w, h, angle=0.0, fill="#00798c", rx=0.0):
    return (f'<rect x="{_f(-w / 2)}" y="{_f(-h / 2)}" width="{_f(w)}" height="{_f(h)}" '
            f'rx="{_f(rx)}" fill="{fill}" transform="translate({_f(cx)},{_f(cy)}) '
            f'rotate({_f(angle)})"/>')


def swirl(cx, cy, r, angle, stroke="#6a4c93"):
    pts = [(cx + r * t / 6 * math.cos(angle + t), cy + r * t / 6 * math.sin(angle + t))
           for t in np.linspace(0, 6, 30)]
    return (f'<polyline points="{_pts(pts)}" fill="none" stroke="{stroke}" stroke-width="2" '
            f'stroke-linecap="round"/>')


def svg(body: list[str], defs: str = "") -> str:
    head = (f'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
            f'width="{_f(SIZE)}" height="{_f(SIZE)}" viewBox="0 0 {_f(SIZE)} {_f(SIZE)}">\n')
    d = f"<defs>{defs}</defs>\n" if defs else ""
    return head + d + "\n".join(body) + "\n</svg>\n"


def make_all(rng: np.random.Generator) -> dict[str, str]:
    ex = {}
    ex["stars"] = svg([star(x, y, rng.uniform(9, 12), rot=rng.uniform(0, 1.2))
                       for x, y in scatter(rng, 30, 30)])
    ex["leaves"] = svg([leaf(x, y, rng.uniform(20, 26), rng.uniform(0, 180))
                        for x, y in scatter(rng, 30, 30)])
    ex["flowers"] = svg([flower(x, y, rng.uniform(10, 13), rot=rng.uniform(0, 1))
                         for x, y in scatter(rng, 24, 32)])
    ex["hearts"] = svg([heart(x, y, rng.uniform(16, 20), rng.uniform(-30, 30))
                        for x, y in scatter(rng, 34, 28)])
    ex["packed_circles"] = svg([f'<circle cx="{_f(x)}" cy="{_f(y)}" r="{_f(rng.uniform(7, 9))}" '
                                f'fill="#edae49"/>' for x, y in scatter(rng, 80, 19, 4)])
    ex["packed_tiles"] = svg([rect(x, y, 14, 9, rng.uniform(-20, 20), rx=2)
                              for x, y in scatter(rng, 70, 20, 4)])
    ex["rings"] = svg([ring(x, y, rng.uniform(7, 10)) for x, y in scatter(rng, 34, 27)])
    ex["swirls"] = svg([swirl(x, y, 12, rng.uniform(0, 6.28)) for x, y in scatter(rng, 26, 32)])
    body = []
    for x, y in scatter(rng, 26, 32):  # two kinds
        body.append(star(x, y, 10, rot=rng.uniform(0, 1)) if rng.random() < 0.5
                    else f'<circle cx="{_f(x)}" cy="{_f(y)}" r="7" fill="#30638e"/>')
    ex["stars_and_dots"] = svg(body)
    body = []
    for x, y in scatter(rng, 28, 30):  # three kinds
        k = rng.integers(3)
        body.append([leaf(x, y, 22, rng.uniform(0, 180)), flower(x, y, 11),
                     heart(x, y, 16)][k])
    ex["garden"] = svg(body)
    body = []
    for x, y in scatter(rng, 30, 30):  # four kinds, some stroke-only
        k = rng.integers(4)
        body.append([star(x, y, 10), ring(x, y, 8), rect(x, y, 14, 8, rng.uniform(0, 90)),
                     swirl(x, y, 11, rng.uniform(0, 6))][k])
    ex["mixed_four"] = svg(body)
    body = []
    for x, y in scatter(rng, 22, 34):  # layered: big disc under an overlapping star
        body.append(f'<circle cx="{_f(x)}" cy="{_f(y)}" r="12" fill="#9bc1bc"/>')
        body.append(star(x + 6, y - 5, 9, fill="#ed6a5a"))
    ex["layered_discs"] = svg(body)
    body = []
    for x, y in scatter(rng, 32, 24):  # overlapping leaves: neighbors cross each other
        body.append(leaf(x, y, 34, rng.uniform(20, 70), fill=f"#{rng.integers(40, 90):02x}a05a"))
    ex["overlapping_leaves"] = svg(body)
    defs = ('<radialGradient id="glow"><stop offset="0" stop-color="#fff6a5"/>'
            '<stop offset="1" stop-color="#f49d37"/></radialGradient>'
            '<path id="petal" d="M 0 0 C 4 -6 4 -12 0 -16 C -4 -12 -4 -6 0 0 Z"/>')
    body = []
    for x, y in scatter(rng, 20, 36):  # <use> + gradient defs
        rot = rng.uniform(0, 72)
        uses = "".join(f'<use xlink:href="#petal" transform="rotate({_f(rot + 72 * j)})"/>'
                       for j in range(5))
        body.append(f'<g transform="translate({_f(x)},{_f(y)})" fill="url(#glow)">{uses}</g>')
    ex["gradient_blossoms"] = svg(body, defs)
    return ex


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "cvt/exemplars"))
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in make_all(np.random.default_rng(args.seed)).items():
        (out / f"{name}.svg").write_text(text)
        print(f"wrote {out / name}.svg")


if __name__ == "__main__":
    main()
