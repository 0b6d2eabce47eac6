"""Votes of matched neighborhoods on pairs of output samples (seed 000 eqs. 5-7, 10-11).

Every matched pair of neighborhoods (n_i, n_o) in the search step's field votes on each pair of
output samples (s_o, s'_o) that n_o contains (both matched, not outliers): do their matched
input samples share an input cluster (seed 000 eq. 11: link confidence), and is m_s(s_o) below
m_s(s'_o) (seed 000 eq. 7: depth order)? Both the clustering step and depth order read these counts.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from cvt.search import Matches
from cvt.torus import Torus


@dataclass
class PairVotes:
    """Counts over unordered output sample pairs a < b that some matched neighborhood holds.

    ``n`` is |N_n(a, b)| (seed 000 eq. 6), ``same`` |N_l(a, b)| (seed 000 eq. 11), ``below``
    |N_z(a, b)| and ``above`` |N_z(b, a)| (seed 000 eq. 7). All tensors have shape (P,).
    """

    a: torch.Tensor  # long
    b: torch.Tensor  # long
    n: torch.Tensor  # long
    same: torch.Tensor  # long
    below: torch.Tensor  # long
    above: torch.Tensor  # long

    @property
    def link(self) -> torch.Tensor:
        """Link confidence l(a, b) (seed 000 eq. 10). Shape: (P,) float64."""
        return self.same.double() / self.n.double()

    def select(self, keep: torch.Tensor) -> PairVotes:
        return PairVotes(self.a[keep], self.b[keep], self.n[keep], self.same[keep],
                         self.below[keep], self.above[keep])


def pair_votes(m: Matches, out_pos: torch.Tensor, in_cluster: torch.Tensor,
               in_z: torch.Tensor, max_dist: float, torus: Torus | None = None) -> PairVotes:
    """Count the votes of all matched neighborhoods on output pairs closer than ``max_dist``.

    Shape: m over N output samples, out_pos (N, 2), in_cluster / in_z (M,) -> PairVotes.
    """
    n = out_pos.shape[0]
    members = torch.cat([torch.arange(n)[:, None], m.out_nbr], 1)  # (N, K+1) output samples
    inputs = torch.cat([m.center[:, None], m.matched], 1)  # (N, K+1) their matched inputs
    ok = (members >= 0) & (inputs >= 0)
    k1 = members.shape[1]
    p = out_pos[members.clamp_min(0)]  # (N, K+1, 2)
    if torus is not None:  # each neighbourhood seen from its centre, across the seam
        p = out_pos[:, None] + torus.diff(p - out_pos[:, None])
    pair = ok[:, :, None] & ok[:, None, :] & torch.ones(k1, k1, dtype=torch.bool).triu(1)
    pair &= torch.cdist(p, p) < max_dist  # (N, K+1, K+1) slot pairs to count
    o, j, k = torch.nonzero(pair, as_tuple=True)  # (V,) each
    a, b, ia, ib = members[o, j], members[o, k], inputs[o, j], inputs[o, k]
    swap = a > b  # store each pair once, as a < b, with its input pair swapped along
    a, b = torch.where(swap, b, a), torch.where(swap, a, b)
    ia, ib = torch.where(swap, ib, ia), torch.where(swap, ia, ib)
    key, inv = torch.unique(a * n + b, return_inverse=True)  # (P,), (V,)

    def count(mask: torch.Tensor) -> torch.Tensor:
        return torch.zeros(len(key), dtype=torch.long).index_add_(0, inv, mask.long())

    za, zb = in_z[ia], in_z[ib]
    return PairVotes(key // n, key % n, count(torch.ones_like(ia, dtype=torch.bool)),
                     count(in_cluster[ia] == in_cluster[ib]), count(za < zb), count(za > zb))
