"""Graph cuts on link confidences: the clustering step's split operator (normalized cuts, Shi &
Malik 2000) and the comparison baseline's k-way spectral clustering (Von Luxburg 2007, used by
seed 000 sec. 7.2).
"""

from __future__ import annotations

import numpy as np
from scipy.cluster.vq import kmeans2
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

_EPS = 1e-6  # weight added to every pair so that isolated samples still belong to the graph


def _normalized_embedding(w: np.ndarray, dims: int) -> np.ndarray:
    """Rows of the ``dims`` smallest eigenvectors of the random-walk Laplacian.

    Shape: w (n, n) symmetric >= 0 -> (n, dims).
    """
    w = w + _EPS
    np.fill_diagonal(w, 0.0)
    d = w.sum(1)
    inv = 1.0 / np.sqrt(d)
    lap = np.eye(len(w)) - inv[:, None] * w * inv[None, :]  # L_sym
    _, vec = np.linalg.eigh(lap)
    return vec[:, :dims] * inv[:, None]  # D^-1/2 v: eigenvectors of L_rw


def normalized_cut(w: np.ndarray) -> np.ndarray:
    """Two-way normalized cut of a weighted graph: the Fiedler vector's sweep cut with the
    smallest Ncut value. Shape: w (n, n), n >= 2 -> (n,) bool, True on one side (both sides
    non-empty)."""
    n = len(w)
    y = _normalized_embedding(w, 2)[:, 1]
    order = np.argsort(y, kind="stable")
    p = w[np.ix_(order, order)]  # (n, n) in sweep order
    deg = p.sum(1)
    assoc = np.cumsum(deg)[:-1]  # (n-1,) assoc(prefix, V)
    inner = np.cumsum(np.cumsum(p, 0), 1).diagonal()[:-1]  # weight inside each prefix
    cut = assoc - inner
    total = deg.sum()
    with np.errstate(divide="ignore", invalid="ignore"):
        ncut = cut / assoc + cut / (total - assoc)
    k = int(np.nanargmin(ncut)) if np.isfinite(ncut).any() else n // 2 - 1
    side = np.zeros(n, dtype=bool)
    side[order[: k + 1]] = True
    return side


def spectral_clusters(a: np.ndarray, b: np.ndarray, weight: np.ndarray, n: int, k: int,
                      seed: int = 0) -> np.ndarray:
    """k-way normalized spectral clustering (Ng-Jordan-Weiss style embedding + k-means) of an
    n-node graph given as edges (a, b, weight). k is shared among connected components (weight
    > 0) in proportion to their size. Shape: a, b, weight (E,) -> (n,) labels 0..K'-1."""
    pos = weight > 0
    g = coo_matrix((weight[pos], (a[pos], b[pos])), shape=(n, n)).tocsr()
    g = g + g.T
    n_comp, comp = connected_components(g, directed=False)
    labels = np.zeros(n, dtype=np.int64)
    next_id = 0
    rng = np.random.default_rng(seed)
    for c in range(n_comp):
        idx = np.flatnonzero(comp == c)
        kc = min(len(idx), max(1, round(k * len(idx) / n)))
        if kc == 1:
            labels[idx] = next_id
        else:
            emb = _normalized_embedding(g[idx][:, idx].toarray(), kc)
            emb = emb / np.maximum(np.linalg.norm(emb, axis=1, keepdims=True), 1e-12)
            _, lab = kmeans2(emb, kc, minit="++", seed=rng)
            labels[idx] = next_id + np.unique(lab, return_inverse=True)[1]
        next_id = int(labels[idx].max()) + 1
    return labels
