"""Curve exemplars -> sample graphs: junctions, crossings, loops, bad strokes."""

import time

import numpy as np
import pytest
import torch

from cvt.curves.graph import CurveGraph, canonical_edges, nearest_edges
from cvt.curves.sampling import exemplar_graph, resample
from cvt.curves.strokes import curve_exemplar, looks_like_curves
from cvt.svg import parse_svg
from neuraltex.errors import InputError


def _svg(body: str, box: str = "0 0 100 100") -> bytes:
    return f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="{box}">{body}</svg>'.encode()


CROSS = _svg('<path d="M10 50 L90 50" stroke="black" fill="none" stroke-width="2"/>'
             '<path d="M50 10 L50 90" stroke="red" fill="none"/>'
             '<path d="M20 50 L20 80" stroke="black" fill="none"/>'
             '<circle cx="70" cy="75" r="10" stroke="blue" fill="none"/>'
             '<circle cx="80" cy="20" r="3" fill="green"/>')


def test_crossing_t_junction_loop_and_element():
    cx = curve_exemplar(parse_svg(CROSS))
    g = exemplar_graph(cx, 5.0)
    deg = g.degree()
    cross = g.pos[deg == 4]
    assert cross.shape[0] == 1 and torch.allclose(cross[0], torch.tensor([50.0, 50.0]).double())
    tee = g.pos[deg == 3]
    assert tee.shape[0] == 1 and torch.allclose(tee[0], torch.tensor([20.0, 50.0]).double())
    assert int((deg == 1).sum()) == 5  # four arm ends and the T's foot
    assert int((g.kind >= 0).sum()) == 1 and int(deg[g.kind >= 0].sum()) == 0  # the dot
    edge_len = (g.pos[g.edges[:, 0]] - g.pos[g.edges[:, 1]]).norm(dim=1)
    assert float(edge_len.max()) < 1.6 * 5.0
    # colours and widths become styles: 2 px black, 1 px red, 1 px black, blue
    assert [(s.color, s.width) for s in g.styles] == [("#000000", 2.0), ("#ff0000", 1.0),
                                                     ("#000000", 1.0), ("#0000ff", 1.0)]
    ring = g.style == 3
    assert bool((deg[ring] == 2).all()) and int(ring.sum()) >= 10  # a closed loop


def test_bad_strokes_are_skipped_or_rejected():
    only_bad = _svg('<path d="M10 10 L10 10" stroke="black" fill="none"/>'
                    '<path d="M10 10" stroke="black" fill="none"/>')
    with pytest.raises(InputError):
        curve_exemplar(parse_svg(only_bad))
    with pytest.raises(InputError):  # stroke="none" and no fill: nothing drawable
        curve_exemplar(parse_svg(_svg('<path d="M0 0 L9 9" stroke="none" fill="none"/>')))
    mixed = _svg('<path d="M10 10 L10 10" stroke="black" fill="none"/>'
                 '<path d="M10 20 L90 20" stroke="black" fill="none"/>')
    assert len(curve_exemplar(parse_svg(mixed)).strokes) == 1


def test_many_tiny_segments_are_fast():
    x = np.linspace(0, 100, 100_001)
    pts = " L".join(f"{a:.4f},{50 + 10 * np.sin(a / 5):.4f}" for a in x[::5])
    cx = curve_exemplar(parse_svg(_svg(f'<path d="M{pts}" stroke="black" fill="none"/>')))
    t = time.perf_counter()
    g = exemplar_graph(cx, 4.0)
    assert time.perf_counter() - t < 5
    assert int((g.degree() == 1).sum()) == 2 and len(g.edges) == len(g) - 1


def test_resample_keeps_ends_and_spacing():
    p = np.array([[0.0, 0.0], [10.0, 0.0]])
    q = resample(p, False, 3.0)
    assert np.allclose(q[0], p[0]) and np.allclose(q[-1], p[-1])
    assert np.diff(q[:, 0]).max() <= 3.0


def test_graph_select_cat_and_nearest_edges():
    pos = torch.tensor([[0.0, 0], [1, 0], [2, 0], [10, 0]]).double()
    minus = torch.full((4,), -1)
    g = CurveGraph(pos, torch.zeros(4, dtype=torch.long), minus, minus, torch.ones(4).double(),
                   minus, canonical_edges(torch.tensor([[1, 0], [1, 2], [2, 2]])), [])
    assert g.edges.tolist() == [[0, 1], [1, 2]]
    sub = g.select(torch.tensor([1, 2, 3]))
    assert sub.edges.tolist() == [[0, 1]]
    both = g.cat(sub)
    assert len(both) == 7 and both.edges.tolist()[-1] == [4, 5]
    assert nearest_edges(g.with_(edges=g.edges[:0]), 1.5).tolist() == [[0, 1], [1, 2]]


def test_auto_detection():
    assert looks_like_curves(parse_svg(CROSS))
    dots = _svg('<circle cx="20" cy="20" r="5" fill="black"/><circle cx="60" cy="60" r="5" '
                'stroke="black" fill="none"/>')
    assert not looks_like_curves(parse_svg(dots))


def test_huge_zigzag_is_rejected_in_one_line():
    pts = " L".join(f"{(k % 2) * 100},{k * 1e-3:.3f}" for k in range(20_000))
    cx = curve_exemplar(parse_svg(_svg(f'<path d="M{pts}" stroke="black" fill="none"/>')))
    with pytest.raises(InputError, match="too long"):
        exemplar_graph(cx, 2.0)


def test_self_intersecting_path_gets_a_crossing():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    pts = " L".join(f"{50 + 30 * np.sin(a):.3f},{50 + 20 * np.sin(2 * a):.3f}" for a in t)
    cx = curve_exemplar(parse_svg(_svg(f'<path d="M{pts} Z" stroke="black" fill="none"/>')))
    g = exemplar_graph(cx, 4.0)
    deg = g.degree()
    assert int((deg == 4).sum()) == 1 and int((deg == 1).sum()) == 0
    assert torch.allclose(g.pos[deg == 4][0], torch.tensor([50.0, 50.0]).double(), atol=0.5)


def test_groups_with_transforms_are_strokes():
    body = ('<g transform="translate(10,0)" stroke="#123456" stroke-width="3" fill="none">'
            '<polyline points="0,10 40,10 40,50"/><line x1="0" y1="80" x2="60" y2="80"/></g>')
    cx = curve_exemplar(parse_svg(_svg(body)))
    assert len(cx.strokes) == 2 and [(s.color, s.width) for s in cx.styles] == [("#123456", 3)]
    assert np.allclose(cx.strokes[0].points[0], [10, 10])  # the group's translate applied


def test_an_end_snaps_to_the_nearest_other_stroke_not_its_own():
    # the foot ends 1 unit above line A (y = 50): joins it at x = 30, not the nearer-by arc of
    # its own stroke; the hook's end comes back 1 unit from its own start: not joined to itself
    svg = _svg('<path d="M10 50 L90 50" stroke="black" fill="none"/>'
               '<path d="M30 20 L30 49" stroke="black" fill="none"/>'
               '<path d="M60 80 L70 80 L70 85 L61 81" stroke="black" fill="none"/>')
    g = exemplar_graph(curve_exemplar(parse_svg(svg)), 5.0)
    tee = g.pos[g.degree() == 3]
    assert tee.shape[0] == 1 and torch.allclose(tee[0], torch.tensor([30.0, 50.0]).double(),
                                                atol=0.6)
    hook = (g.pos[:, 1] > 70)
    assert int((g.degree()[hook] == 1).sum()) == 2
