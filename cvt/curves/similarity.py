"""Sample similarity of curve samples as the feature table of cvt's neighborhood distance.

cvt's batched eq. 2 / seed 001 eq. 7 adds ``table[o, i]`` (times w_f / 2) to the position
term of every sample pair it matches, so the curve attributes enter there:

* edges (seed 001 eq. 5): the edge set of a sample is embedded as a sum of von Mises bumps on
  a ring of direction bins, one unit-norm bump per edge; the squared distance of two such sums
  is small when the edges can be matched one to one with similar directions and grows by
  about 1 (= lambda, one sampling distance) per unmatched edge. This replaces the per-pair
  Hungarian matching of edges by an embedding whose distance table is one matrix product.
  Samples without edges (new ones) get no edge term (seed 001: lambda = 0 for them).
* style (eq. 3 attribute term): a constant when the stroke styles differ.
* ids (eq. 4, sec. 4.2.3): curve samples only match curve samples and discrete elements only
  the same kind; a mismatch costs ``forbid``, above any outlier cost.
"""

from __future__ import annotations

import math

import torch

from cvt.curves.graph import CurveGraph

BINS = 12
KAPPA = 3.0


def edge_embedding(g: CurveGraph) -> torch.Tensor:
    """Sum over a sample's edges of unit-norm direction bumps. Shape: -> (N, BINS)."""
    emb = torch.zeros(len(g), BINS, dtype=torch.float64)
    if g.edges.numel() == 0:
        return emb
    a, b = g.edges[:, 0], g.edges[:, 1]
    src = torch.cat([a, b])
    d = torch.cat([g.pos[b] - g.pos[a], g.pos[a] - g.pos[b]])  # (2E, 2) outgoing directions
    ang = torch.atan2(d[:, 1], d[:, 0])
    centers = torch.arange(BINS, dtype=torch.float64) * (2 * math.pi / BINS)
    bump = torch.exp(KAPPA * (torch.cos(ang[:, None] - centers[None]) - 1))  # (2E, BINS)
    bump = bump / bump.norm(dim=1, keepdim=True)
    return emb.index_add_(0, src, bump)


def feature_table(out: CurveGraph, inp: CurveGraph, w_edge: float = 1.0, w_style: float = 1.0,
                  forbid: float = 100.0, in_emb: torch.Tensor | None = None) -> torch.Tensor:
    """Attribute cost of every (output, input) sample pair. Shape: -> (N_out, N_in)."""
    table = torch.zeros(len(out), len(inp), dtype=torch.float64)
    if w_edge > 0:
        e_in = edge_embedding(inp) if in_emb is None else in_emb
        e_out = edge_embedding(out)
        table += w_edge * torch.cdist(e_out, e_in) ** 2
        table[out.degree() == 0] = 0.0  # new samples: lambda = 0, eq. 5 vanishes
    if w_style > 0:
        table += w_style * (out.style[:, None] != inp.style[None]).double()
    table += forbid * (out.kind[:, None] != inp.kind[None]).double()
    return table
