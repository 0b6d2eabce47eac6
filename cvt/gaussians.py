"""Gaussian elements: an exemplar whose elements are 2D Gaussians (textons, seed 003 eq. 4.2).

A Gaussian (mu, U) stands for the uniform region with the same moments (seed 003 eqs.
4.3-4.4): the ellipse x^T U^-1 x <= ``LEVEL``^2 (semi-axes 2 sqrt(eig U)). That ellipse is the
element's shape, so the engine samples it like any filled SVG shape (seed 000 sec. 4) and
arranges, clusters and reconstructs it unchanged; the per-element appearance attributes A(s)
(seed 000 sec. 4.2) carry what the Gaussian's position and shape do not (its appearance
feature, size and kind). An element is one Gaussian, or a group of them (the textons of one
object, :mod:`neuraltex.texton_groups`) sampled as one element of several shapes; an element's
``index`` is its group's position, so a placement (element, dx, dy) names the Gaussians it
copies. Each Gaussian is written as an ``<ellipse>`` (``data-gaussian`` = its row; a group as a
``<g>`` of them), so the same arrangement also renders as SVG.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np

from cvt.svg import SVG_NS, Element, Exemplar, Shape

LEVEL = 2.0  # Mahalanobis radius of the element outline: the uniform region of covariance U
POINTS = 24  # outline vertices per ellipse


def ellipse_ring(mu: np.ndarray, cov: np.ndarray, level: float = LEVEL,
                 n: int = POINTS) -> np.ndarray:
    """Outline of {x : (x - mu)^T cov^-1 (x - mu) <= level^2}. Shape: (2,), (2, 2) -> (n, 2)."""
    evals, evecs = np.linalg.eigh(cov)
    axes = level * np.sqrt(np.clip(evals, 1e-18, None))  # (2,)
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    circle = np.stack([np.cos(t), np.sin(t)], 1) * axes  # (n, 2) in the eigenbasis
    return mu + circle @ evecs.T


def _node(index: int, mu: np.ndarray, cov: np.ndarray, fill: str) -> ET.Element:
    evals, evecs = np.linalg.eigh(cov)
    rx, ry = LEVEL * np.sqrt(np.clip(evals[::-1], 0, None))  # major axis first
    angle = math.degrees(math.atan2(evecs[1, 1], evecs[0, 1]))
    return ET.Element(f"{{{SVG_NS}}}ellipse", {
        "cx": f"{mu[0]:.6g}", "cy": f"{mu[1]:.6g}", "rx": f"{rx:.6g}", "ry": f"{ry:.6g}",
        "transform": f"rotate({angle:.4g} {mu[0]:.6g} {mu[1]:.6g})", "fill": fill,
        "data-gaussian": str(index)})


def gaussian_exemplar(mu: np.ndarray, cov: np.ndarray, appearance: np.ndarray,
                      canvas: tuple[float, float], fills: list[str] | None = None,
                      groups: list[list[int]] | None = None) -> Exemplar:
    """An exemplar of Gaussian elements on the canvas [0, w] x [0, h], bottom to top in the
    order given; ``groups`` (default: one Gaussian each) are the rows making each element.
    Shape: mu (E, 2), cov (E, 2, 2), appearance (len(groups), D); ``fills`` are the
    ellipses' SVG colours (default grey)."""
    mu, cov = np.asarray(mu, np.float64), np.asarray(cov, np.float64)
    if mu.ndim != 2 or mu.shape[1] != 2 or cov.shape != (len(mu), 2, 2):
        raise ValueError(f"need mu (E, 2) and cov (E, 2, 2), got {mu.shape}, {cov.shape}")
    groups = [[i] for i in range(len(mu))] if groups is None else groups
    if len(appearance) != len(groups):
        raise ValueError(f"appearance has {len(appearance)} rows for {len(groups)} elements")
    fills = fills or ["#808080"] * len(mu)
    elements = []
    for k, rows in enumerate(groups):
        nodes = [_node(i, mu[i], cov[i], fills[i]) for i in rows]
        node = nodes[0] if len(nodes) == 1 else ET.Element(f"{{{SVG_NS}}}g")
        if len(nodes) > 1:
            node.extend(nodes)
        elements.append(Element(k, node, [Shape([ellipse_ring(mu[i], cov[i])], [True], True,
                                                0.0) for i in rows]))
    w, h = canvas
    return Exemplar(elements, (0.0, 0.0, float(w), float(h)),
                    appearance=np.asarray(appearance, np.float64),
                    note=f"{len(elements)} Gaussian elements")
