"""The outline of an element, and how well one element's fits another's place.

Elements that trade places (:mod:`neuraltex.element_swap`) are first carried onto each other
by the affine map that matches their pixel moments; what still differs is the outline: a
stone with a pointed corner arriving where a rounder one was leaves the corner's ground
behind and misses the other's bulge. The outline of footprint k is its radius as a function
of the direction, r_k(phi), in k's own *moment frame*

    w = diag(l_k)^-1/2 V_k^T (x - c_k)          (elongated: whitened, Sigma_k = V diag(l) V^T)
    w = det(Sigma_k)^-1/4 (x - c_k)             (round: scaled, never turned)

in which the moment map between two elements is the identity (up to the flips of V's columns
that :func:`neuraltex.element_swap.place_map` chooses: four variants of each elongated
outline). Carried onto place p, element e's outline misses p's by the stretch
s(phi) = r_e(phi) / r_p(phi); how far s strays from 1, in ratio and in pixels, and how much of
each outline's area the other covers, say whether e fits p's place.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

BINS = 32      # directions of an outline
HARMONICS = 4  # an outline keeps the first harmonics of its radius over the directions
FLIPS = np.array([[1, 1], [-1, 1], [1, -1], [-1, -1]], float)  # signs of V's two columns


@dataclass
class Outlines:
    whitened: np.ndarray  # (E, 4, BINS) radius per direction in the whitened frame, per flip
    round: np.ndarray     # (E, BINS) radius per direction in the scaled frame
    vectors: np.ndarray   # (E, 2, 2) V_k, eigenvectors (columns) of each element's covariance
    values: np.ndarray    # (E, 2) l_k, eigenvalues (ascending)


def radii(w: np.ndarray) -> np.ndarray | None:
    """(n, 2) points around the origin -> (BINS,) their largest radius per direction bin
    (bins without a point interpolated), kept to its first HARMONICS harmonics over the
    circle: the shape of a stone, not the ragged edge of a segment (stretching a coin onto
    every notch of its place's segment would dent it); None for fewer than 3 occupied
    bins."""
    b = np.floor((np.arctan2(w[:, 1], w[:, 0]) + math.pi) / (2 * math.pi) * BINS)
    b = b.astype(np.int64) % BINS
    r = np.full(BINS, np.nan)
    np.fmax.at(r, b, np.hypot(w[:, 0], w[:, 1]))
    ok = ~np.isnan(r)
    if ok.sum() < 3:
        return None
    x = np.arange(BINS)
    r = np.interp(x, x[ok], r[ok], period=BINS)
    spectrum = np.fft.rfft(r)
    spectrum[HARMONICS + 1:] = 0
    return np.maximum(np.fft.irfft(spectrum, BINS), 0.5 * r.min())


def outlines(place: np.ndarray, centre: np.ndarray, cov: np.ndarray) -> Outlines:
    """Outlines of the E footprints of ``place`` (H, W; element whose place each pixel is,
    -1: none), in the moment frames of the elements' centres (E, 2) x, y and pixel
    covariances (E, 2, 2). A footprint with too few pixels gets a unit circle."""
    E = len(centre)
    values, vectors = np.linalg.eigh(cov)                      # (E, 2), (E, 2, 2)
    whitened, round_ = np.ones((E, 4, BINS)), np.ones((E, BINS))
    ys, xs = np.nonzero(place >= 0)
    who = place[ys, xs]
    order = np.argsort(who, kind="stable")
    starts = np.searchsorted(who[order], np.arange(E + 1))
    pts = np.stack([xs, ys], 1)[order].astype(np.float64)
    for k in range(E):
        u = pts[starts[k]:starts[k + 1]] - centre[k]           # (n, 2)
        if len(u) < 3:
            continue
        w = (u @ vectors[k]) / np.sqrt(values[k])              # whitened, (n, 2)
        for f, sign in enumerate(FLIPS):
            r = radii(w * sign)
            whitened[k, f] = 1.0 if r is None else r
        r = radii(u / np.prod(values[k]) ** 0.25)
        round_[k] = 1.0 if r is None else r
    return Outlines(whitened, round_, vectors, values)


def flip_index(vectors: np.ndarray, e: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(n,) which FLIPS row carries element e's frame onto p's: the signs that turn p's
    eigenvectors toward e's (:func:`neuraltex.element_swap.place_map`)."""
    dots = np.einsum("nij,nij->nj", vectors[p], vectors[e])    # (n, 2) column dot products
    neg = dots < 0
    return neg[:, 0].astype(np.int64) + 2 * neg[:, 1].astype(np.int64)


def stretch(o: Outlines, e: np.ndarray, p: np.ndarray, round_: np.ndarray) -> np.ndarray:
    """(n, BINS) s(phi) = r_e / r_p for the pairs (e -> place of p), each in the frame its
    moment map uses (``round_`` (n,) bool: scaled, else whitened)."""
    f = flip_index(o.vectors, e, p)
    s_white = o.whitened[e, f] / o.whitened[p, 0]
    s_round = o.round[e] / o.round[p]
    return np.where(round_[:, None], s_round, s_white)


def shift_pixels(o: Outlines, s: np.ndarray, p: np.ndarray, round_: np.ndarray) -> np.ndarray:
    """(n,) largest distance, in pixels, between the outline carried onto place p and p's
    own, for stretches s (n, BINS) (:func:`stretch`): |s - 1| r_p times p's frame's pixels
    per unit (its long axis' standard deviation; det^1/4 for the scaled frame)."""
    r = np.where(round_[:, None], o.round[p], o.whitened[p, 0])
    scale = np.where(round_, np.prod(o.values[p], 1) ** 0.25, np.sqrt(o.values[p, 1]))
    return (np.abs(s - 1) * r).max(1) * scale


def cover(s: np.ndarray) -> np.ndarray:
    """(n, BINS) stretches r_e / r_p -> (n,) the smaller of the shares of p's outline area
    and of e's (carried onto p) that the other covers: sum min(r_e, r_p)^2 over the larger
    of sum r_e^2 and sum r_p^2, with r_p = 1 (the area of a star-shaped outline is
    1/2 the integral of r^2 over the directions)."""
    both = np.minimum(s, 1.0) ** 2
    return both.sum(1) / np.maximum((s ** 2).sum(1), BINS)
