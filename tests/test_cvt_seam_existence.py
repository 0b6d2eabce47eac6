"""Existence on a torus (tileable output): the vote cells tile the period (no sliver of a
cell at the seam), and two new samples across the seam are as close as any two."""

import torch

from cvt.assignment import _places, _spaced
from cvt.torus import Torus

TORUS = Torus((0.0, 0.0), (100.0, 80.0))


def test_vote_cells_tile_the_period():
    # 100 / 3: 33 cells of 3.03 (cells of 3 from 0 left a sliver [99, 100) at the seam)
    votes = torch.tensor([[97.5, 41.0], [99.9, 41.2], [0.1, 41.0], [50.0, 10.0], [50.4, 10.2]])
    uniq, inv, place, first = _places(votes, 3.0, TORUS)
    assert inv[0] == inv[1] != inv[2] and inv[3] == inv[4]
    assert torch.allclose(place[inv[0]], torch.tensor([98.7, 41.1]))
    assert int(first[inv[0]]) == 0 and int(first[inv[3]]) == 3
    _, inv_plane, _, _ = _places(votes, 3.0, None)
    assert inv_plane[0] != inv_plane[1]  # on a plane: [96, 99) and [99, 102)


def test_spaced_sees_points_across_the_seam():
    pts = [[0.5, 40.0], [99.5, 40.0], [50.0, 79.8], [50.0, 0.3], [20.0, 20.0], [24.0, 20.0]]
    assert _spaced(pts, 3.0, TORUS) == [0, 2, 4, 5]
    assert _spaced(pts, 3.0) == [0, 1, 2, 3, 4, 5]  # on a plane they are far apart
    assert _spaced(pts, 5.0) == [0, 1, 2, 3, 4]  # 4 apart: too close at gap 5
