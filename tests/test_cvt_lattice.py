"""Kinds, fragments and lattices (cvt/kinds.py, cvt/lattice.py)."""

import numpy as np

from cvt.kinds import cut_mask, element_kinds, exact_kinds
from cvt.lattice import detect_lattice, lattice_copies
from cvt.pattern import synthesize_pattern
from cvt.svg import parse_svg
from cvt.synthesis import SynthesisConfig

NS = 'xmlns="http://www.w3.org/2000/svg"'
X = '<path d="M{0},{1} l4,4 M{2},{1} l-4,4" stroke="black" stroke-width="1" fill="none"/>'
O = '<circle cx="{0}" cy="{1}" r="2" fill="none" stroke="black"/>'


def _grid(n: int = 6, step: float = 10.0, jitter: float = 0.0, seed: int = 0) -> bytes:
    rng = np.random.default_rng(seed)
    body = []
    for i in range(n):
        for j in range(n):
            x, y = 5 + i * step + rng.normal(0, jitter), 5 + j * step + rng.normal(0, jitter)
            if (i + j) % 2:
                body.append(X.format(x - 2, y - 2, x + 2))
            else:
                body.append(O.format(x, y))
    side = n * step
    return f'<svg {NS} viewBox="0 0 {side:g} {side:g}">{"".join(body)}</svg>'.encode()


def _analyse(ex):
    boxes = np.stack([e.bbox for e in ex.elements])
    cut = cut_mask(ex.elements, ex.viewbox)
    kinds = element_kinds(ex.elements, cut)
    return boxes, cut, kinds, (boxes[:, :2] + boxes[:, 2:]) / 2


def test_x_and_o_are_different_kinds():
    ex = parse_svg(_grid(2))
    _, _, kinds, _ = _analyse(ex)
    assert len(set(kinds.tolist())) == 2 and kinds[0] != kinds[1]


def test_fragments_are_cut_on_the_border_but_tangent_dots_are_whole():
    doc = (f'<svg {NS} viewBox="0 0 20 20"><path d="M0,5 A5,5 0 0 1 0,15 Z"/>'
           '<circle cx="3" cy="3" r="3"/><circle cx="10" cy="10" r="2"/>'
           '<circle cx="19" cy="10" r="3"/></svg>').encode()
    cut = cut_mask(parse_svg(doc).elements, (0, 0, 20, 20))
    assert cut.tolist() == [True, False, False, False]  # half disc; tangent; inside; past


def test_checkerboard_of_x_and_o_has_a_lattice_and_tiles_it():
    ex = parse_svg(_grid())
    boxes, cut, kinds, centers = _analyse(ex)
    lat = detect_lattice(centers, kinds, boxes, ~cut, ex.viewbox)
    assert lat is not None and len(lat.reps) == 2 and lat.explained > 0.95
    area = abs(lat.a[0] * lat.b[1] - lat.a[1] * lat.b[0])
    assert np.isclose(area, 200)  # one X and one O per cell of 2 x 10 x 10
    copies = lattice_copies(lat, boxes, (0, 0, 120, 120))
    c = np.array([(centers[e] + [dx, dy]).round(6) for e, dx, dy in copies])
    assert len(c) == len(np.unique(c, axis=0)) == 144  # no stacked duplicates, no holes
    assert {kinds[e] for e, _, _ in copies} == set(kinds.tolist())


def test_jittered_grid_still_has_a_lattice_but_a_random_layout_has_none():
    ex = parse_svg(_grid(jitter=0.4))
    boxes, cut, kinds, centers = _analyse(ex)
    assert detect_lattice(centers, kinds, boxes, ~cut, ex.viewbox) is not None
    rng = np.random.default_rng(1)
    body = "".join(O.format(*rng.uniform(3, 57, 2)) for _ in range(30))
    ex = parse_svg(f'<svg {NS} viewBox="0 0 60 60">{body}</svg>'.encode())
    boxes, cut, kinds, centers = _analyse(ex)
    assert detect_lattice(centers, kinds, boxes, ~cut, ex.viewbox) is None


def _mirrored_rows() -> bytes:
    """Rows of triangles pointing up and down in turn (a motif and its mirror image)."""
    body = []
    for j in range(6):
        for i in range(6):
            x, y = 2 + i * 10, 2 + j * 10
            d = f"M{x},{y + 6} L{x + 3},{y} L{x + 6},{y + 6} Z" if j % 2 else \
                f"M{x},{y} L{x + 3},{y + 6} L{x + 6},{y} Z"
            body.append(f'<path d="{d}"/>')
    return f'<svg {NS} viewBox="0 0 60 60">{"".join(body)}</svg>'.encode()


def test_mirror_images_are_one_kind_but_not_one_exact_kind():
    ex = parse_svg(_mirrored_rows())
    _, _, kinds, _ = _analyse(ex)
    exact = exact_kinds(ex.elements, kinds)
    assert len(set(kinds.tolist())) == 1 and len(set(exact.tolist())) == 2
    assert exact[0] == exact[1] != exact[6]  # along a row the same, the next row mirrored


def test_mirrored_rows_keep_their_alternation():
    ex = parse_svg(_mirrored_rows())
    cfg = SynthesisConfig(levels=1, iterations=1, seed=0)
    pattern = synthesize_pattern(ex, (120.0, 120.0), cfg)
    lat = pattern.lattice
    assert lat is not None and len(lat.reps) == 2
    assert np.isclose(abs(lat.a[0] * lat.b[1] - lat.a[1] * lat.b[0]), 200)  # 10 x 20 cell
    # every placed triangle points the way its row does in the exemplar
    for e, dx, dy in pattern.placements:
        assert round(dy / 10) % 2 == 0, (e, dx, dy)


def _render(ex, pattern) -> np.ndarray:
    """The pattern's SVG at 1 px per unit. Shape: -> (H, W, 3)."""
    import io

    from PIL import Image

    from cvt.pattern import pattern_svg
    from cvt.raster import png_bytes

    png = png_bytes(pattern_svg(ex, pattern), width=round(pattern.size[0]))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.float32) / 255


def test_tileable_lattice_at_an_odd_scale_snaps_to_whole_periods_and_tiles_without_seam():
    from pathlib import Path

    from cvt.pattern import PatternOptions
    from cvt.svg import load_svg

    ex = load_svg(Path(__file__).parents[1] / "data" / "cvt_real" / "hero_ticTacToe.svg", "auto")
    cfg = SynthesisConfig(levels=1, iterations=1, seed=0)
    size = (1.7 * ex.viewbox[2], 1.7 * ex.viewbox[3])  # 326.4: not a whole number of periods
    tile = synthesize_pattern(ex, size, cfg, opts=PatternOptions(tileable=True))
    assert tile.size == (320.0, 320.0)  # the nearest whole number (5) of its 64 x 64 periods
    assert any("snapped to 320 x 320" in n for n in tile.notes)
    # the tile, tiled 2 x 2, is the lattice itself over the doubled canvas, pixel for pixel
    plane = synthesize_pattern(ex, (640.0, 640.0), cfg)
    tiled = np.tile(_render(ex, tile), (2, 2, 1))  # (640, 640, 3)
    assert np.abs(tiled - _render(ex, plane)).max() < 2 / 255
    # without --tileable the size is the user's
    assert synthesize_pattern(ex, size, cfg).size == size


def test_axis_periods_make_a_hexagonal_lattice_exact_and_refuse_an_irrational_one():
    from cvt.lattice import Lattice, axis_periods

    hexa = Lattice(np.array([10.0, 0.0]), np.array([5.0, 8.6603]), np.array([0]), 1.0)
    lat, period = axis_periods(hexa)
    assert np.allclose(period, [10.0, 2 * 8.6603])  # 2 b - a lies along y
    assert np.allclose(2 * lat.b - lat.a, [0.0, period[1]], atol=1e-12)
    assert np.allclose(lat.b, hexa.b, atol=1e-3)  # moved by its rounding at most
    skew = Lattice(np.array([10.0, 0.0]), np.array([np.sqrt(2) * 10 / 3, 9.0]), np.array([0]), 1.0)
    assert axis_periods(skew) is None


def _cells(n: int = 5, step: float = 10.0, vary: bool = False):
    """n x n cells of side ``step``, each with two elements; with ``vary`` the second one's
    place differs from cell to cell (the cells' content varies, the grid stays)."""
    c = []
    for i in range(n):
        for j in range(n):
            c.append([i * step + 3, j * step + 4])
            c.append([i * step + 6 + (0.1 * (i * n + j) if vary else 0), j * step + 7])
    c = np.array(c)
    return c, np.c_[c - 1, c + 1]


def test_cell_copies_continue_identical_cells_without_holes_or_stacks():
    from cvt.lattice import cell_copies

    centers, boxes = _cells()
    basis = np.array([[10.0, 0], [0, 10]])
    copies = cell_copies(basis, centers, boxes, (0, 0, 50, 50), (0, 0, 120, 70),
                         np.random.default_rng(0))
    p = np.array([centers[e] + [dx, dy] for e, dx, dy in copies]).round(6)
    assert len(p) == len(np.unique(p, axis=0))  # no element stacked on another
    inside = p[(p[:, 0] > 1) & (p[:, 0] < 119) & (p[:, 1] > 1) & (p[:, 1] < 69)]
    expected = {(x + 3, y + 4) for x in range(0, 120, 10) for y in range(0, 70, 10)}
    expected |= {(x + 6, y + 7) for x in range(0, 120, 10) for y in range(0, 70, 10)}
    assert {tuple(q) for q in inside} == {q for q in expected if 1 < q[0] < 119 and 1 < q[1] < 69}


def test_cell_copies_draw_each_cell_from_a_random_whole_cell_seeded():
    from cvt.lattice import cell_copies

    centers, boxes = _cells(vary=True)
    basis = np.array([[10.0, 0], [0, 10]])
    run = [cell_copies(basis, centers, boxes, (0, 0, 50, 50), (0, 0, 100, 100),
                       np.random.default_rng(s)) for s in (0, 0, 1)]
    assert run[0] == run[1] and run[0] != run[2]  # deterministic per seed
    sources = {e // 2 for e, _, _ in run[0]}  # the exemplar cell each copy came from
    assert len(sources) > 10  # many different cells, not one cell repeated
    for _, dx, dy in run[0]:  # whole cells only: every shift is a lattice vector
        assert np.allclose(np.round(np.array([dx, dy]) / 10) * 10, [dx, dy])


def test_cell_copies_on_a_torus_repeat_with_its_periods():
    from cvt.lattice import cell_copies, torus_cells

    centers, boxes = _cells(vary=True)
    basis = np.array([[10.0, 0], [0, 10]])
    assert torus_cells(basis, (60, 40)).tolist() == [[6, 0], [0, 4]]
    assert torus_cells(basis, (65, 40)) is None  # not a whole number of cells
    copies = cell_copies(basis, centers, boxes, (0, 0, 50, 50), (0, 0, 130, 90),
                         np.random.default_rng(3), torus=(60, 40))  # two periods and more
    at = {}
    for e, dx, dy in copies:
        x, y = centers[e] + [dx, dy]
        at[(round(x, 6), round(y, 6))] = e
    pairs = 0
    for (x, y), e in at.items():  # a copy one period away is the same element
        for ox, oy in ((60, 0), (0, 40)):
            if (round(x + ox, 6), round(y + oy, 6)) in at:
                assert at[(round(x + ox, 6), round(y + oy, 6))] == e
                pairs += 1
    assert pairs > 100
    free = cell_copies(basis, centers, boxes, (0, 0, 50, 50), (0, 0, 130, 90),
                       np.random.default_rng(3))
    assert {(e, dx, dy) for e, dx, dy in free} != {(e, dx, dy) for e, dx, dy in copies}


def test_cell_copies_need_a_whole_cell_in_the_exemplar():
    from cvt.lattice import cell_copies

    centers, boxes = _cells(n=2)
    basis = np.array([[30.0, 0], [0, 30]])  # larger than the 20 x 20 exemplar
    assert cell_copies(basis, centers, boxes, (0, 0, 20, 20), (0, 0, 60, 60),
                       np.random.default_rng(0)) is None
