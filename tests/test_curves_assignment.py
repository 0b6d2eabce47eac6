"""Curve similarity, edge and existence assignment, reconstruction."""

import itertools

import numpy as np
import pytest
import torch

from cvt.curves.edges import assign_edges, expected_degree
from cvt.curves.existence import existence
from cvt.curves.reconstruction import bezier_d, trace_paths
from cvt.curves.sampling import exemplar_graph
from cvt.curves.similarity import MAX_EDGES, edge_set_distance, feature_table
from cvt.curves.strokes import curve_exemplar
from cvt.neighborhood import neighborhoods
from cvt.search import Matches
from cvt.svg import parse_svg

SVG = (b'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
       b'<path d="M10 50 L90 50" stroke="black" fill="none"/>'
       b'<path d="M50 10 L50 90" stroke="black" fill="none"/>'
       b'<circle cx="25" cy="25" r="10" stroke="black" fill="none"/>'
       b'<circle cx="80" cy="20" r="3" fill="green"/></svg>')


def _graph():
    return exemplar_graph(curve_exemplar(parse_svg(SVG)), 5.0)


def _identity(g):
    nbr = neighborhoods(g.pos, 15.0, 12)
    return Matches(torch.arange(len(g)), nbr, nbr.clone(), torch.zeros(len(g)))


def test_edges_from_a_perfect_match_are_the_input_edges():
    g = _graph()
    m = _identity(g)
    out = g.with_(edges=g.edges[:0])  # no edges yet
    edges = assign_edges(m, out, g, reach=11.0)
    assert edges.tolist() == g.edges.tolist()
    assert torch.allclose(expected_degree(m, out, g), g.degree().double())


def test_kept_edges_stay():
    g = _graph()
    keep = torch.tensor([[0, 30]])
    edges = assign_edges(_identity(g), g.with_(edges=g.edges[:0]), g, 11.0, keep=keep)
    assert [0, 30] in edges.tolist()


def test_existence_counts_unmatched_neighborhoods():
    g = _graph()
    m = _identity(g)
    assert torch.all(existence(m, len(g)) == 1)
    victim = 7
    matched = torch.where(m.out_nbr == victim, -1, m.matched)
    m2 = Matches(m.center, m.out_nbr, matched, m.cost)
    xi = existence(m2, len(g))
    assert xi[victim] < 0.5 and torch.all(xi[torch.arange(len(g)) != victim] == 1)


@pytest.mark.parametrize("edge_term", ["embedding", "matching"])
def test_feature_table_edges_styles_and_kinds(edge_term):
    g = _graph()
    t = feature_table(g, g, edge_term=edge_term, delta=5.0)
    assert torch.allclose(t.diagonal(), torch.zeros(len(g)).double())
    curve, dot = torch.nonzero(g.kind < 0).flatten()[0], torch.nonzero(g.kind >= 0).flatten()[0]
    assert t[curve, dot] >= 100 and t[dot, curve] >= 100
    deg = g.degree()
    end, mid = torch.nonzero(deg == 1).flatten()[0], torch.nonzero(deg == 2).flatten()[0]
    assert t[end, mid] > 0.5  # one edge unmatched (eq. 5's lambda)
    bare = g.with_(edges=g.edges[:0])
    bare_t = feature_table(bare, g, edge_term=edge_term, delta=5.0)
    assert torch.all(bare_t[g.kind < 0][:, g.kind < 0] == 0)  # lambda = 0


def _brute_eq5(u, has, v, hv, lam=1.0):
    """Eq. 5 by listing every one-to-one matching of two small edge sets."""
    a = [u[j] for j in range(len(u)) if has[j]]
    b = [v[k] for k in range(len(v)) if hv[k]]
    best = lam * (len(a) + len(b))  # nothing matched
    for n in range(1, min(len(a), len(b)) + 1):
        for ja in itertools.permutations(range(len(a)), n):
            for kb in itertools.permutations(range(len(b)), n):
                sq = sum(float(((a[j] - b[k]) ** 2).sum()) for j, k in zip(ja, kb, strict=True))
                best = min(best, sq + lam * (len(a) + len(b) - 2 * n))
    return best


def test_eq5_matching_is_the_least_cost_one_to_one_matching():
    gen = torch.Generator().manual_seed(3)
    u = torch.randn(40, MAX_EDGES, 2, generator=gen, dtype=torch.float64) * 0.7
    count = torch.randint(0, MAX_EDGES + 1, (40,), generator=gen)
    has = torch.arange(MAX_EDGES)[None] < count[:, None]  # a sample's edges fill its first slots
    got = edge_set_distance(u[:10], has[:10], u, has)
    for p in range(10):
        for q in range(0, 40, 3):
            assert abs(float(got[p, q]) - _brute_eq5(u[p], has[p], u[q], has[q])) < 1e-9
    assert torch.allclose(got[torch.arange(10), torch.arange(10)], torch.zeros(10).double())


def test_paths_loop_closed_and_crossing_straight():
    g = _graph()
    curves = g.select(torch.nonzero(g.kind < 0).flatten())
    paths = trace_paths(curves)
    assert len(paths) == 3  # two straight strokes through the crossing, one closed ring
    assert sum(p.closed for p in paths) == 1
    used = sorted(tuple(sorted(e)) for p in paths for e in
                  zip(p.nodes, p.nodes[1:] + ([p.nodes[0]] if p.closed else []), strict=False))
    assert used == sorted(map(tuple, curves.edges.tolist()))  # each edge exactly once
    d = bezier_d(np.array([[0.0, 0], [1, 0], [2, 0]]), False)
    assert d.startswith("M0.00,0.00 C") and d.count("C") == 2 and not d.endswith("Z")
    assert bezier_d(np.array([[0.0, 0], [1, 0], [1, 1]]), True).endswith("Z")
