"""Signed distance functions of texton shapes in a unit local frame.

Every shape has "radius" about 1 in local coordinates ``(u, v)``; negative inside.
The caller scales the result back to normalized image units. For polygons and stars
the value is exact inside and a close bound outside, which is all anti-aliasing needs.
"""

from __future__ import annotations

import numpy as np

KINDS = ("ellipse", "polygon", "star", "box", "leaf", "capsule", "blob")


def sdf(kind: str, u: np.ndarray, v: np.ndarray, t: dict) -> np.ndarray:
    """Signed distance of shape ``kind`` at local coordinates. Shape: (h, w) -> (h, w).

    ``t`` holds the texton's shape parameters: ``n`` (polygon/star sides), ``star``
    (star indentation 0..1), ``corner`` (box rounding), ``width`` (leaf/capsule
    half-width), ``wobble`` (list of (amplitude, frequency, phase) for blobs).
    """
    if kind == "ellipse":
        return np.sqrt(u * u + v * v) - 1.0
    if kind == "polygon":
        return _polygon(u, v, int(t.get("n", 6)))
    if kind == "star":
        return _star(u, v, int(t.get("n", 5)), float(t.get("star", 0.45)))
    if kind == "box":
        c = float(t.get("corner", 0.2))
        qx, qy = np.abs(u) - (1.0 - c), np.abs(v) - (1.0 - c)
        outside = np.sqrt(np.maximum(qx, 0) ** 2 + np.maximum(qy, 0) ** 2)
        return outside + np.minimum(np.maximum(qx, qy), 0.0) - c
    if kind == "leaf":
        return _vesica(u, v, float(t.get("width", 0.45)))
    if kind == "capsule":
        w = float(t.get("width", 0.15))
        du = np.abs(u) - np.minimum(np.abs(u), 1.0 - w)
        return np.sqrt(du * du + v * v) - w
    if kind == "blob":
        rho = np.sqrt(u * u + v * v)
        theta = np.arctan2(v, u)
        radius = 1.0
        for amp, freq, phase in t.get("wobble", ()):
            radius = radius + amp * np.sin(freq * theta + phase)
        return (rho - radius) * 0.8
    raise ValueError(f"unknown shape kind {kind!r}; expected one of {KINDS}")


def _polygon(u: np.ndarray, v: np.ndarray, n: int) -> np.ndarray:
    # Regular n-gon inscribed in the unit circle: distance to the nearest edge line.
    sector = 2.0 * np.pi / n
    theta = np.arctan2(v, u)
    a = np.mod(theta + sector / 2.0, sector) - sector / 2.0
    return np.sqrt(u * u + v * v) * np.cos(a) - np.cos(np.pi / n)


def _star(u: np.ndarray, v: np.ndarray, n: int, depth: float) -> np.ndarray:
    # Radius modulated between 1 (tips) and 1 - depth (valleys); scaled to stay a bound.
    theta = np.arctan2(v, u)
    radius = 1.0 - depth * (0.5 - 0.5 * np.cos(n * theta))
    return (np.sqrt(u * u + v * v) - radius) * (0.55 + 0.45 * (1.0 - depth))


def _vesica(u: np.ndarray, v: np.ndarray, width: float) -> np.ndarray:
    # Intersection of two discs: pointed tips at u = +-1, half-width ``width`` at u = 0.
    r = (1.0 + width * width) / (2.0 * width)
    off = r - width
    d1 = np.sqrt(u * u + (v - off) ** 2) - r
    d2 = np.sqrt(u * u + (v + off) ** 2) - r
    return np.maximum(d1, d2)
