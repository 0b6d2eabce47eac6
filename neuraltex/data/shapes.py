"""Signed distance functions of texton shapes in a unit local frame.

Every shape has "radius" about 1 in local coordinates ``(u, v)``; negative inside.
The caller scales the result back to normalized image units. For polygons and stars
the value is exact inside and a close bound outside, which is all anti-aliasing needs.
"""

from __future__ import annotations

import numpy as np

KINDS = ("ellipse", "polygon", "star", "box", "leaf", "capsule", "blob")


def sdf(kind: str, u: np.ndarray, v: np.ndarray, t: dict) -> np.ndarray:
    """Signed distance of shape ``kind`` at local coordinates. Shape: (K, h, w) -> (K, h, w).

    ``t`` holds the shape parameters, scalars or (K,) arrays: ``n`` (polygon/star
    sides), ``star`` (star indentation 0..1), ``corner`` (box rounding), ``width``
    (leaf/capsule half-width), ``wobble`` ((K, M, 3) amplitude, frequency, phase of M
    radial sine bumps for blobs).
    """
    if kind == "ellipse":
        return np.sqrt(u * u + v * v) - 1.0
    if kind == "polygon":
        return _polygon(u, v, _param(t, "n", 6))
    if kind == "star":
        return _star(u, v, _param(t, "n", 5), _param(t, "star", 0.45))
    if kind == "box":
        c = _param(t, "corner", 0.2)
        qx, qy = np.abs(u) - (1.0 - c), np.abs(v) - (1.0 - c)
        outside = np.sqrt(np.maximum(qx, 0) ** 2 + np.maximum(qy, 0) ** 2)
        return outside + np.minimum(np.maximum(qx, qy), 0.0) - c
    if kind == "leaf":
        return _vesica(u, v, _param(t, "width", 0.45))
    if kind == "capsule":
        w = _param(t, "width", 0.15)
        du = np.abs(u) - np.minimum(np.abs(u), 1.0 - w)
        return np.sqrt(du * du + v * v) - w
    if kind == "blob":
        rho = np.sqrt(u * u + v * v)
        theta = np.arctan2(v, u)
        radius = np.float32(1.0)
        wobble = np.asarray(t.get("wobble", np.zeros((len(u), 0, 3))), np.float32)
        for m in range(wobble.shape[1]):
            amp, freq, phase = (wobble[:, m, j, None, None] for j in range(3))
            radius = radius + amp * np.sin(freq * theta + phase)
        return (rho - radius) * 0.8
    raise ValueError(f"unknown shape kind {kind!r}; expected one of {KINDS}")


def _param(t: dict, key: str, default: float) -> np.ndarray:
    """A shape parameter as a scalar or a (K, 1, 1) array that broadcasts over windows."""
    p = np.asarray(t.get(key, default), np.float32)
    return p[:, None, None] if p.ndim == 1 else p


def _polygon(u: np.ndarray, v: np.ndarray, n: np.ndarray) -> np.ndarray:
    # Regular n-gon inscribed in the unit circle: distance to the nearest edge line.
    sector = 2.0 * np.pi / n
    theta = np.arctan2(v, u)
    a = np.mod(theta + sector / 2.0, sector) - sector / 2.0
    return np.sqrt(u * u + v * v) * np.cos(a) - np.cos(np.pi / n)


def _star(u: np.ndarray, v: np.ndarray, n: np.ndarray, depth: np.ndarray) -> np.ndarray:
    # Radius modulated between 1 (tips) and 1 - depth (valleys); scaled to stay a bound.
    theta = np.arctan2(v, u)
    radius = 1.0 - depth * (0.5 - 0.5 * np.cos(n * theta))
    return (np.sqrt(u * u + v * v) - radius) * (0.55 + 0.45 * (1.0 - depth))


def _vesica(u: np.ndarray, v: np.ndarray, width: np.ndarray) -> np.ndarray:
    # Intersection of two discs: pointed tips at u = +-1, half-width ``width`` at u = 0.
    r = (1.0 + width * width) / (2.0 * width)
    off = r - width
    d1 = np.sqrt(u * u + (v - off) ** 2) - r
    d2 = np.sqrt(u * u + (v + off) ** 2) - r
    return np.maximum(d1, d2)
