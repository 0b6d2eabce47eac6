"""Existence assignment for curve samples (seed 001 sec. 4.3.4, eq. 16, appendix A).

Removal: a sample's existence is the share of the neighborhoods containing it in which it was
matched; below 1/2 it goes. Addition: input samples left unmatched inside matched input
neighborhoods vote for a missing output sample at the corresponding place (cvt's
``missing_votes``); places voted for by more than half of the overlapping output neighborhoods
get a new sample that copies the voting input sample's attributes, without edges (the next
edge assignment connects it).
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from cvt.assignment import _spaced, missing_votes
from cvt.curves.edges import occurrences
from cvt.curves.graph import CurveGraph
from cvt.search import Matches


def existence(m: Matches, n: int) -> torch.Tensor:
    """Eq. 16 for present samples. Shape: -> (N,) float (1 for samples in no neighborhood)."""
    outs, ins = occurrences(m)
    ok = outs >= 0
    o = outs[ok]
    hit = (ins[ok] >= 0).double()
    total = torch.bincount(o, minlength=n).double()
    matched = torch.zeros(n, dtype=torch.float64).index_add_(0, o, hit)
    return torch.where(total > 0, matched / total.clamp_min(1), torch.ones(n, dtype=torch.float64))


def missing_samples(out: CurveGraph, m: Matches, inp: CurveGraph, in_nbr: torch.Tensor,
                    delta: float, radius: float, inside: Callable[[torch.Tensor], torch.Tensor],
                    threshold: float = 0.5, grow: torch.Tensor | None = None,
                    grow_threshold: float = 0.25) -> CurveGraph:
    """New samples where eq. 16 says one is missing (possibly none). ``grow`` (M, 2): stroke
    ends the matches do not back (cvt.curves.ends); within 1.5 ``delta`` of one a place needs
    only ``grow_threshold`` of the votes: the stroke runs on toward where it continues."""
    p, s_i, s_o = missing_votes(out, m, inp, in_nbr, radius)  # (V, 2), (V,), (V,)
    ok = inside(p) if p.shape[0] else torch.zeros(0, dtype=torch.bool)
    p, s_i, s_o = p[ok], s_i[ok], s_o[ok]
    if p.shape[0] == 0:
        return CurveGraph.empty(out.styles)
    cell = torch.floor(p / delta).long()  # votes landing in one cell are one place
    _, inv = torch.unique(cell, dim=0, return_inverse=True)
    places = int(inv.max()) + 1
    count = torch.bincount(inv, minlength=places).double()
    place = torch.zeros(places, 2, dtype=p.dtype).index_add_(0, inv, p) / count[:, None]
    voters = torch.unique(inv * len(out) + s_o)  # a neighborhood votes once per place
    n_vote = torch.bincount(voters // len(out), minlength=places).double()
    near = torch.cdist(place, out.pos) if len(out) else torch.full((places, 1), float("inf"))
    overlap = (near <= radius).sum(1).clamp_min(1)
    xi = n_vote / overlap
    need = torch.full((places,), threshold, dtype=xi.dtype)
    if grow is not None and len(grow):
        need[torch.cdist(place, grow).min(1).values < 1.5 * delta] = grow_threshold
    good = torch.nonzero((xi > need) & (near.min(1).values >= 0.8 * delta)).flatten()
    good = good[torch.argsort(xi[good], descending=True, stable=True)]
    kept = good[_spaced(place[good].tolist(), 0.8 * delta)]
    if kept.numel() == 0:
        return CurveGraph.empty(out.styles)
    first = torch.full((places,), len(inv), dtype=torch.long)
    first.scatter_reduce_(0, inv, torch.arange(len(inv)), reduce="amin")
    src = s_i[first[kept]]  # (A,) one voting input sample per new sample
    return CurveGraph(place[kept], inp.style[src], inp.kind[src], inp.element[src], xi[kept],
                      src, torch.zeros(0, 2, dtype=torch.long), out.styles)
