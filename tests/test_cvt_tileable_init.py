"""The init grid of a tileable output (cvt.initialization.patch_grid on a torus): its lines,
where copied patches meet and cut elements crowd, must not sit on the seam every time."""

import numpy as np
import torch

from cvt.initialization import gaussian_init, patch_grid, patch_init
from cvt.sampling import Samples
from cvt.torus import Torus

IN_BOX = (0.0, 0.0, 100.0, 80.0)
OUT_BOX = (0.0, 0.0, 250.0, 170.0)


def _grid(seed, torus):
    return patch_grid(IN_BOX, OUT_BOX, 60.0, torch.Generator().manual_seed(seed), torus)


def _inp(n=400, seed=0):
    """Input samples: small elements of 4 samples each at random places. Shape: pos (n, 2)."""
    g = torch.Generator().manual_seed(seed)
    cluster = torch.arange(n) // 4
    centre = torch.rand(n // 4, 2, generator=g, dtype=torch.float64) * torch.tensor([96.0, 76.0])
    pos = centre[cluster] + 2 + torch.rand(n, 2, generator=g, dtype=torch.float64) * 2 - 1
    return Samples(pos, cluster, cluster.clone(), torch.ones(n, dtype=torch.float64),
                   torch.zeros(n, 60, dtype=torch.float64), cluster.clone(), torch.arange(n))


def test_plain_grid_starts_at_the_canvas_corner():
    pw, ph, cells = _grid(1, None)
    assert (pw, ph) == (60.0, 60.0)
    assert cells[0] == (0.0, 0.0) and len(cells) == 5 * 3  # last row and column cut


def test_torus_grid_tiles_the_period_at_a_random_offset():
    torus = Torus.of(OUT_BOX)
    offsets = set()
    for seed in range(4):
        pw, ph, cells = _grid(seed, torus)
        c = np.array(cells)  # (C, 2)
        nx, ny = len(np.unique(c[:, 0])), len(np.unique(c[:, 1]))
        assert np.isclose(nx * pw, 250.0) and np.isclose(ny * ph, 170.0)  # whole cells
        assert len(cells) == nx * ny and pw <= 100.0 and ph <= 80.0  # within the input
        x0, y0 = c.min(0)
        assert 0.0 <= x0 < pw and 0.0 <= y0 < ph
        offsets.add((round(x0, 6), round(y0, 6)))
    assert len(offsets) == 4 and (0.0, 0.0) not in offsets  # the seam is no grid line


def test_torus_grid_keeps_cells_no_larger_than_the_input():
    torus = Torus.of(OUT_BOX)
    pw, ph, _ = patch_grid(IN_BOX, OUT_BOX, 500.0, torch.Generator().manual_seed(0), torus)
    assert pw <= 100.0 and ph <= 80.0
    assert np.isclose(250.0 / pw, round(250.0 / pw)) and np.isclose(170.0 / ph, round(170.0 / ph))


def test_torus_init_keeps_every_copied_sample_over_one_period():
    """Plain: samples past the canvas are dropped. Torus: the grid covers exactly one period
    (from its offset), so nothing is dropped and every place of the canvas is covered once."""
    inp, torus = _inp(), Torus.of(OUT_BOX)
    out = patch_init(inp, IN_BOX, OUT_BOX, 60.0, torch.Generator().manual_seed(3), torus)
    pw, ph, cells = _grid(3, torus)
    lo = np.array(cells).min(0)
    pos = out.pos.numpy()
    assert (pos >= lo - 1e-9).all() and (pos < lo + [250.0, 170.0] + 1e-9).all()
    # about the input's density everywhere on the torus, seam included
    wrapped = torus.wrap(out.pos).numpy()
    near_seam = (np.minimum(wrapped, [250.0, 170.0] - wrapped) < 10).any(1).mean()
    band = 1 - (230 / 250) * (150 / 170)  # share of the canvas within 10 of a seam line
    assert abs(near_seam - band) < 0.1
    assert abs(len(out) / (250 * 170) - len(inp) / (100 * 80)) < 0.25 * len(inp) / (100 * 80)


def test_gaussian_init_sees_a_copy_across_the_seam():
    """A Gaussian centre by the left edge covers a point by the right edge on a torus only."""
    from cvt.initialization import _covered

    centre = torch.tensor([[1.0, 50.0]], dtype=torch.float64)
    prec = torch.eye(2, dtype=torch.float64)[None] / 9.0  # radius 3
    point = torch.tensor([249.0, 50.0], dtype=torch.float64)
    assert _covered(point, centre, prec, Torus.of(OUT_BOX))
    assert not _covered(point, centre, prec)


def test_gaussian_init_on_a_torus_keeps_one_period():
    inp, torus = _inp(), Torus.of(OUT_BOX)
    out = gaussian_init(inp, IN_BOX, OUT_BOX, 60.0, torch.Generator().manual_seed(2), torus)
    lo = np.array(_grid(2, torus)[2]).min(0)
    pos = out.pos.numpy()
    assert (pos > lo - 5).all() and (pos < lo + [255.0, 175.0]).all()
    assert (pos > [250.0, 170.0]).any(0).all() or lo.min() < 1  # copies past the far edge kept


def test_a_missing_element_voted_from_both_sides_of_the_seam_is_one_cluster():
    """Two output samples (clusters 0 and 1) on either side of the seam, matched to one input
    sample, both vote for the same missing input element (cluster 7): on a torus the new
    samples share one fresh cluster; without the torus the translations differ by a period."""
    from cvt.assignment import _new_cluster_ids
    from cvt.search import Matches

    n_in = 8
    inp = Samples(torch.tensor([[50.0, 40.0]] * n_in, dtype=torch.float64),
                  torch.arange(n_in), torch.zeros(n_in, dtype=torch.long),
                  torch.ones(n_in, dtype=torch.float64),
                  torch.zeros(n_in, 60, dtype=torch.float64), torch.arange(n_in),
                  torch.arange(n_in))
    out = Samples(torch.tensor([[249.0, 60.0], [-1.0 + 0.5, 60.0]], dtype=torch.float64),
                  torch.tensor([0, 1]), torch.zeros(2, dtype=torch.long),
                  torch.ones(2, dtype=torch.float64), torch.zeros(2, 60, dtype=torch.float64),
                  torch.tensor([0, 1]), torch.tensor([0, 1]))
    m = Matches(torch.tensor([0, 0]), torch.full((2, 1), -1), torch.full((2, 1), -1),
                torch.zeros(2))
    s_i, s_o = torch.tensor([7, 7]), torch.tensor([0, 1])
    on = _new_cluster_ids(out, m, inp, s_i, s_o, 20.0, Torus.of(OUT_BOX))
    off = _new_cluster_ids(out, m, inp, s_i, s_o, 20.0)
    assert on[0] == on[1] and int(on[0]) > 1  # one fresh cluster
    assert off[0] != off[1]
