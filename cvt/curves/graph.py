"""The sample-graph representation of a pattern (seed 001 sec. 4.1, eq. 1).

Every sample has a position, attributes (a stroke style for curve samples, an element kind for
discrete elements), an existence confidence and graph edges to the samples it is connected to
along a stroke. Discrete elements are single samples with ``kind >= 0`` and no edges; curve
samples have ``kind == -1`` (seed 001 sec. 4.2.3: negative ids are continuous structures).
Orientation attributes (the tangents at a sample) are not stored: they are the directions of
its edges, which is what eq. 6 matches them to anyway.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch


@dataclass(frozen=True)
class StrokeStyle:
    color: str  # '#rrggbb'
    width: float  # user units


@dataclass
class CurveGraph:
    """All per-sample tensors share the first dimension N; ``edges`` index into them."""

    pos: torch.Tensor  # (N, 2) float64
    style: torch.Tensor  # (N,) long, index into ``styles`` (curve samples), -1 for elements
    kind: torch.Tensor  # (N,) long, -1 curve sample, >= 0 discrete element kind (same shape)
    element: torch.Tensor  # (N,) long, exemplar element drawn at a discrete sample, else -1
    exist: torch.Tensor  # (N,) float, existence confidence
    source: torch.Tensor  # (N,) long, input sample this one copies / -1
    edges: torch.Tensor  # (E, 2) long, undirected, a < b, no duplicates
    styles: list[StrokeStyle]

    def __len__(self) -> int:
        return self.pos.shape[0]

    @staticmethod
    def empty(styles: list[StrokeStyle]) -> CurveGraph:
        z = torch.zeros(0, dtype=torch.long)
        return CurveGraph(torch.zeros(0, 2, dtype=torch.float64), z, z, z, z.double(), z,
                          torch.zeros(0, 2, dtype=torch.long), styles)

    def with_(self, **kw) -> CurveGraph:
        return replace(self, **kw)

    def degree(self) -> torch.Tensor:
        """Shape: -> (N,) long."""
        return torch.bincount(self.edges.flatten(), minlength=len(self))

    def select(self, idx: torch.Tensor) -> CurveGraph:
        """Samples ``idx`` (long indices, unique) and the edges among them, renumbered."""
        new = torch.full((len(self),), -1, dtype=torch.long)
        new[idx] = torch.arange(idx.numel())
        e = new[self.edges] if self.edges.numel() else self.edges
        e = e[(e >= 0).all(1)] if e.numel() else e
        return CurveGraph(*(getattr(self, f)[idx] for f in _PER_SAMPLE), e, self.styles)

    def cat(self, other: CurveGraph) -> CurveGraph:
        """Both graphs side by side (``other``'s styles must be the same list)."""
        cat = [torch.cat([getattr(self, f), getattr(other, f)]) for f in _PER_SAMPLE]
        return CurveGraph(*cat, torch.cat([self.edges, other.edges + len(self)]), self.styles)

    def with_edges(self, edges: torch.Tensor) -> CurveGraph:
        return self.with_(edges=canonical_edges(edges))

    def adjacency(self) -> list[list[int]]:
        nbr: list[list[int]] = [[] for _ in range(len(self))]
        for a, b in self.edges.tolist():
            nbr[a].append(b)
            nbr[b].append(a)
        return nbr


_PER_SAMPLE = ("pos", "style", "kind", "element", "exist", "source")


def canonical_edges(edges: torch.Tensor) -> torch.Tensor:
    """Undirected edges as sorted unique (a, b), a < b, self loops dropped. Shape: (E, 2)."""
    if edges.numel() == 0:
        return edges.reshape(0, 2).long()
    e = torch.sort(edges.long(), dim=1).values
    e = e[e[:, 0] != e[:, 1]]
    return torch.unique(e, dim=0) if e.numel() else e.reshape(0, 2)


def edge_keys(edges: torch.Tensor, n: int) -> torch.Tensor:
    """One integer per undirected edge (for set lookups). Shape: (E, 2) -> (E,)."""
    e = torch.sort(edges, dim=1).values
    return e[:, 0] * n + e[:, 1]


def components(n: int, edges: np.ndarray) -> tuple[int, np.ndarray]:
    """Connected components of the graph. Shape: edges (E, 2) -> count, labels (N,)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    return connected_components(m, directed=False)


def nearest_edges(g: CurveGraph, reach: float, k: int = 2) -> torch.Tensor:
    """Each curve sample joined to its ``k`` nearest curve samples of the same style within
    ``reach`` (reconnecting samples synthesized without edges). Shape: -> (E, 2)."""
    from scipy.spatial import cKDTree

    idx = torch.nonzero(g.kind < 0).flatten().numpy()
    if len(idx) < 2:
        return torch.zeros(0, 2, dtype=torch.long)
    pos = g.pos.numpy()[idx]
    dist, nb = cKDTree(pos).query(pos, k=k + 1, distance_upper_bound=reach)
    a = np.repeat(np.arange(len(idx)), k)
    b = nb[:, 1:].reshape(-1)
    ok = np.isfinite(dist[:, 1:].reshape(-1))
    a, b = a[ok], b[ok]
    style = g.style.numpy()[idx]
    same = style[a] == style[b]
    e = np.stack([idx[a[same]], idx[b[same]]], 1)
    return canonical_edges(torch.from_numpy(e))
