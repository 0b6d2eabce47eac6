"""Placed elements bring the reconstruction's pixels (neuraltex.element_paste): cutouts under
the footprints, pastes in draw order that wrap for tileable outputs, and gaps filled from
around the nearest paste."""

import numpy as np
import torch

from neuraltex.element_paste import (
    cutouts,
    element_map,
    element_rank,
    fill_gaps,
    paste,
    pixel_placements,
)


def _scene():
    """A 20 x 30 reconstruction with two square elements (textons 1 and 2) on a ground
    (texton 0), each pixel a different colour so copies can be traced."""
    H, W = 20, 30
    labels = np.zeros((H, W), np.int64)
    labels[4:8, 4:8] = 1
    labels[10:16, 18:24] = 2
    g = torch.Generator().manual_seed(0)
    recon = torch.rand(3, H, W, generator=g)
    rows = np.array([1, 2])  # exemplar rows -> textons; texton 0 is the ground
    return recon, labels, rows


def test_element_map_marks_textons_outside_the_elements_as_ground():
    _, labels, rows = _scene()
    where = element_map(labels, rows, [[0], [1]], K=3)
    assert where[5, 5] == 0 and where[12, 20] == 1 and where[0, 0] == 2


def test_cutout_covers_its_footprint_and_fades_outside():
    recon, labels, rows = _scene()
    pieces = cutouts(recon, labels, rows, [[0], [1]], K=3, margin=0, feather=0.5)
    c = pieces[0]
    y, x = c.corner
    inside = c.alpha[5 - y, 5 - x]
    assert float(inside) > 0.99
    assert float(c.alpha[0, 0]) < 0.01  # beyond the blur's reach
    assert torch.equal(c.rgb[:, 5 - y, 5 - x], recon[:, 5, 5])
    empty = cutouts(recon, labels, rows, [[0], [1], []], K=3)
    assert empty[2] is None


def test_paste_moves_the_pixels_whole_and_wraps_when_tileable():
    recon, labels, rows = _scene()
    pieces = cutouts(recon, labels, rows, [[0], [1]], K=3, margin=0, feather=0.5)
    ground = torch.zeros(3, 24, 40)
    out = paste(ground, pieces, [(0, 10, 20)])  # element 0 moved 10 down, 20 right
    assert torch.allclose(out.image[:, 15, 25], recon[:, 5, 5], atol=1e-3)
    assert float(out.cover[15, 25]) > 0.99 and float(out.cover[0, 0]) == 0
    assert tuple(out.source[15, 25]) == (5, 5) and tuple(out.source[0, 0]) == (-1, -1)
    cut = paste(ground, pieces, [(0, 0, 34)])  # x 38..41: partly beyond the right edge
    wrap = paste(ground, pieces, [(0, 0, 34)], tileable=True)
    assert float(cut.cover[5, :4].max()) == 0
    assert torch.allclose(wrap.image[:, 5, 0], recon[:, 5, 6], atol=1e-3)  # 40 -> 0


def test_later_placements_are_drawn_on_top():
    recon, labels, rows = _scene()
    pieces = cutouts(recon, labels, rows, [[0], [1]], K=3, margin=0, feather=0.5)
    # element 1 (6 x 6 at y 10, x 18) moved onto element 0's place, then element 0 there
    out = paste(torch.zeros(3, 20, 30), pieces, [(1, -6, -14), (0, 0, 0)])
    assert torch.allclose(out.image[:, 5, 5], recon[:, 5, 5], atol=1e-3)
    out = paste(torch.zeros(3, 20, 30), pieces, [(0, 0, 0), (1, -6, -14)])
    assert torch.allclose(out.image[:, 5, 5], recon[:, 11, 19], atol=1e-3)


def test_gaps_take_the_pixels_next_to_the_nearest_paste():
    recon, labels, rows = _scene()
    pieces = cutouts(recon, labels, rows, [[0], [1]], K=3, margin=0, feather=0.5)
    ground = torch.zeros(3, 20, 30)
    pasted = paste(ground, pieces, [(0, 2, 3)])  # element 0 at y 6..9, x 7..10
    out = fill_gaps(pasted, recon, ground, reach=5, feather=0.5)
    # two pixels left of the pasted square: the input's two pixels left of the element
    assert torch.allclose(out[:, 7, 5], recon[:, 5, 2], atol=1e-3)
    assert float(out[:, 19, 29].abs().max()) == 0  # beyond reach: the ground stays
    inside = out[:, 7, 8]
    assert torch.allclose(inside, pasted.image[:, 7, 8], atol=1e-3)  # pastes untouched


def test_placements_in_pixels_sorted_by_draw_rank():
    rank = element_rank(np.array([5, 0, 3]), np.array([1, 2, 0]), [[0], [1, 2]])
    assert rank.tolist() == [0, 3]
    placed = pixel_placements([(0, 0.5, 0.25), (1, 0.1, 0.0), (0, 0.0, 0.0)], rank, 8)
    assert placed == [(0, 2, 4), (0, 0, 0), (1, 0, 1)]


def test_elements_on_a_ground_carry_their_share_of_it():
    from neuraltex.element_paste import ground_margin
    from neuraltex.element_swap import MARGIN

    recon, labels, rows = _scene()
    where = element_map(labels, rows, [[0], [1]], K=3)
    m = ground_margin(where, 2)
    assert MARGIN < m < 10  # the ground between and around the two squares is wide
    pieces = cutouts(recon, labels, rows, [[0], [1]], K=3, feather=0.5)  # margin from the ground
    near, far = 7 + int(m), 7 + int(m) + 2  # columns right of element 0 (x 4..7), row 5
    c = pieces[0]
    row = c.alpha[5 - c.corner[0]]
    assert c.corner[1] == 0 and float(row[near]) > 0.5  # within m px: carried
    assert far >= len(row) or float(row[far]) < 0.5  # beyond: not
    fixed = cutouts(recon, labels, rows, [[0], [1]], K=3, margin=MARGIN, feather=0.5)[0]
    assert fixed.alpha.shape[1] <= near  # the fixed 2 px margin stops short of it
    # no ground (every pixel an element's): the fixed margin, as before
    assert ground_margin(np.zeros((6, 6), np.int64), 2) == MARGIN


def test_a_texture_without_ground_pastes_as_with_the_fixed_margin():
    from neuraltex.element_swap import MARGIN

    recon, labels, rows = _scene()
    labels = np.where(labels == 0, 1, labels)  # the ground becomes part of element 0
    a = cutouts(recon, labels, rows, [[0], [1]], K=3)
    b = cutouts(recon, labels, rows, [[0], [1]], K=3, margin=MARGIN)
    assert all(torch.equal(x.alpha, y.alpha) and x.corner == y.corner for x, y in
               zip(a, b, strict=True))


def test_the_wrap_is_no_join_of_the_fill():
    """On a torus no line is special: moving a tileable paste moves its filled picture with
    it. (The wrap row and column were taken for a join between copies and blurred: the fill
    of every tileable output was soft along its whole wrap.)"""
    H, W = 24, 40
    recon = torch.rand(3, H, W, generator=torch.Generator().manual_seed(1))
    labels = np.zeros((H, W), np.int64)
    labels[8:13, 8:14] = 1
    pieces = cutouts(recon, labels, np.array([1]), [[0]], K=2, margin=0, feather=0.5)
    ground = torch.zeros(3, H, W)

    def filled(dy: int, dx: int) -> torch.Tensor:
        pasted = paste(ground, pieces, [(0, dy, dx)], tileable=True)
        return fill_gaps(pasted, recon, ground, tileable=True, reach=6, feather=0.5)

    base = filled(0, 0)  # the square well inside: its fill does not reach the wrap
    for dy, dx in ((-9, 0), (0, -10), (-9, -10), (6, 21)):  # across a wrap or two
        moved = torch.roll(base, (dy, dx), (-2, -1))
        assert torch.allclose(filled(dy, dx), moved, atol=1e-5), (dy, dx)


def test_copies_a_period_apart_continue_an_exactly_periodic_picture():
    """A 12 x 10 tile repeated 2 x 3 times, one element per tile: pasted at offsets that differ
    by whole periods with gaps between them, the fill with the period continues the tile
    exactly (no blurred joins, no mirroring at the picture's border); without it, it does
    not."""
    g = torch.Generator().manual_seed(1)
    tile = torch.rand(3, 12, 10, generator=g)
    recon = tile.repeat(1, 2, 3)  # (3, 24, 30)
    labels = np.zeros((24, 30), np.int64)
    labels[3:6, 2:5] = 1  # the element: a 3 x 3 patch of the first tile
    pieces = cutouts(recon, labels, np.array([1]), [[0]], K=2, margin=0, feather=0.35)
    placed = [(0, 12 * i, 10 * j) for i in range(-1, 5) for j in range(-1, 7)]
    ground = torch.zeros(3, 48, 60)
    period = np.array([[12, 0], [0, 10]])
    exact = fill_gaps(paste(ground, pieces, placed), recon, ground, period=period)
    assert torch.allclose(exact, tile.repeat(1, 4, 6), atol=1e-6)
    plain = fill_gaps(paste(ground, pieces, placed), recon, ground)
    assert float((plain - tile.repeat(1, 4, 6)).abs().max()) > 0.1
    tiled = fill_gaps(paste(ground, pieces, placed, tileable=True), recon, ground, tileable=True,
                      period=period)
    assert torch.allclose(tiled, tile.repeat(1, 4, 6), atol=1e-6)
