"""The domain shape and eq. 15's pull of samples back into it (cvt.curves.domain)."""

import numpy as np
import torch

from cvt.assignment import assign_positions
from cvt.curves.baselines import finish
from cvt.curves.domain import Domain, deep_inside
from cvt.curves.graph import StrokeStyle
from cvt.curves.init import box_inside
from cvt.curves.sampling import stroke_graph
from cvt.curves.strokes import Stroke
from cvt.neighborhood import neighborhoods
from cvt.search import Matches

BOX = (0.0, 0.0, 100.0, 100.0)
C = torch.tensor([50.0, 50.0], dtype=torch.float64)


def disk(p):
    return (p - C).norm(dim=1) <= 30


def test_border_projection_and_depth_of_a_disk():
    dom = Domain.of(box_inside(BOX, disk), BOX, 0.5)
    p = torch.tensor([[95.0, 50.0], [50.0, 10.0], [50.0, 50.0], [70.0, 50.0]]).double()
    q = dom.project(p)
    r = (q - C).norm(dim=1).numpy()
    assert np.all(np.abs(r - 30) < 1.0) and bool(disk(q).all())  # on the border, inside
    assert abs(float(q[0, 1]) - 50) < 1.0 and abs(float(q[1, 0]) - 50) < 1.0  # nearest
    d = dom.depth(p)
    assert abs(d[0] + 15) < 1 and abs(d[1] + 10) < 1 and abs(d[2] - 30) < 1 and abs(d[3] - 10) < 1
    assert deep_inside(p, disk, 5.0).tolist() == [False, False, True, True]


def test_anchor_pulls_a_sample_and_drags_its_neighbours_along():
    pos = torch.stack([torch.arange(10.0, 90.0, 8.0), torch.full((10,), 50.0)], 1).double()
    nbr = neighborhoods(pos, 20.0, 6)
    m = Matches(torch.arange(len(pos)), nbr, nbr.clone(), torch.zeros(len(pos)))
    free = assign_positions(pos, m, pos)
    torch.testing.assert_close(free, pos, atol=1e-6, rtol=0)  # consistent votes: no move
    target = torch.tensor([[100.0, 60.0]], dtype=torch.float64)
    moved = assign_positions(pos, m, pos, anchor=(torch.tensor([9]), target, 2.0))
    assert (moved[9] - target[0]).norm() < (pos[9] - target[0]).norm()  # toward its target
    step = moved - pos
    assert float(step[8, 1]) > 0.5 * float(step[9, 1]) > 0  # the stroke moves with it
    assert float(step[0].norm()) < float(step[9].norm())


def test_finish_treats_the_domain_border_as_a_cut():
    # lines cut by a disk: their ends lie on its border, not in open paper
    lines = [np.array([[50 - (900 - (y - 50) ** 2) ** 0.5 + 0.5, y],
                       [50 + (900 - (y - 50) ** 2) ** 0.5 - 0.5, y]]) for y in (35.0, 50.0, 65.0)]
    style = [StrokeStyle("#000", 1.0)]
    g = stroke_graph([Stroke(p, False, 0) for p in lines], style, 2.0)
    ex = stroke_graph([Stroke(np.array([[0.0, y], [100.0, y]]), False, 0) for y in (30, 60)],
                      style, 2.0)  # an exemplar without interior ends
    boxed = finish(g, ex, BOX, BOX, 2.0)
    shaped = finish(g, ex, BOX, BOX, 2.0, inside=disk)
    assert int((shaped.degree() == 1).sum()) == 6  # every line kept with its two ends
    assert bool(disk(shaped.pos).all())
    assert int((boxed.degree() == 1).sum()) < 6  # without the shape: ends "in open paper"
