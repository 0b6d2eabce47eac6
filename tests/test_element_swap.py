"""Elements trading places in the picture (neuraltex.element_swap), and the finer elements
inside a background-sized mass (neuraltex.texton_elements._finer_in_background)."""

import numpy as np
import torch

from neuraltex.element_swap import footprints, place_map, swap_elements
from neuraltex.texton_elements import _finer_in_background

H = W = 64
CENTRES = [(16, 16), (16, 48), (48, 16), (48, 48)]  # (y, x)
COLOURS = [(0.9, 0.2, 0.2), (0.2, 0.9, 0.2), (0.2, 0.2, 0.9), (0.9, 0.9, 0.2)]


def discs(radii=(7.0, 7.0, 7.0, 7.0)):
    """Four coloured discs on a grey ground; textons = elements: 0 the ground, 1..4 the discs.
    -> image (3, H, W), labels (H, W), groups (5,)."""
    yy, xx = np.mgrid[0:H, 0:W]
    image = torch.full((3, H, W), 0.5)
    labels = np.zeros((H, W), np.int64)
    for i, ((cy, cx), c, r) in enumerate(zip(CENTRES, COLOURS, radii, strict=True)):
        inside = (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r
        image[:, torch.from_numpy(inside)] = torch.tensor(c)[:, None]
        labels[inside] = i + 1
    return image, labels, np.arange(5)


def colour_at(image, y, x):
    return image[:, y, x]


def test_place_map_matches_the_moments_without_turning_or_flipping():
    rng = np.random.default_rng(0)
    for _ in range(20):
        a, b = rng.normal(size=(2, 2)), rng.normal(size=(2, 2))
        src, dst = a @ a.T + 0.1 * np.eye(2), b @ b.T + 0.1 * np.eye(2)
        A = place_map(src, dst, False)
        assert np.allclose(A @ src @ A.T, dst, atol=1e-9)
        assert np.linalg.det(A) > 0  # a rotation and stretches, never a mirror image
    same = np.array([[4.0, 1.0], [1.0, 2.0]])
    assert np.allclose(place_map(same, same, False), np.eye(2))  # nothing turns in place
    A = place_map(np.eye(2), 2.25 * np.eye(2), True)
    assert np.allclose(A, 1.5 * np.eye(2))  # round: an isotropic scale


def test_elements_trade_places_whole_and_the_ground_stays():
    image, labels, groups = discs()
    out = swap_elements(image, labels, groups, seed=3)
    before = torch.stack([colour_at(image, y, x) for y, x in CENTRES])
    after = torch.stack([colour_at(out, y, x) for y, x in CENTRES])
    # the same four colours, not all in their places
    assert torch.cdist(after, before).amin(1).max() < 1e-4
    assert (after - before).abs().sum(1).gt(0.1).any()
    # each disc arrives whole: its place shows one colour out to 5 px from the centre
    yy, xx = np.mgrid[0:H, 0:W]
    for (cy, cx), c in zip(CENTRES, after, strict=True):
        inside = torch.from_numpy((yy - cy) ** 2 + (xx - cx) ** 2 <= 25)
        assert (out[:, inside] - c[:, None]).abs().max() < 0.05
    # the ground away from the discs is the input's, bit for bit
    far = torch.from_numpy(labels == 0) & torch.from_numpy(
        np.min([(yy - cy) ** 2 + (xx - cx) ** 2 for cy, cx in CENTRES], 0) > 12 ** 2)
    assert torch.equal(out[:, far], image[:, far])
    assert torch.equal(out, swap_elements(image, labels, groups, seed=3))  # deterministic


def test_an_element_is_scaled_to_the_place_it_takes_so_no_hole_is_left():
    """Discs of radius 6 and 7 trade places at --size-ratio 1.5: the smaller disc, scaled
    up, covers the larger one's place out to 6.5 px (unscaled it would leave a grey ring)."""
    image, labels, groups = discs((6.0, 7.0, 6.0, 7.0))
    yy, xx = np.mgrid[0:H, 0:W]
    arrived = 0
    for seed in range(8):
        out = swap_elements(image, labels, groups, seed=seed, size_ratio=1.5)
        for cy, cx in CENTRES[1::2]:  # the large places
            c = colour_at(out, cy, cx)
            arrived += bool((c - colour_at(image, cy, cx)).abs().max() > 0.1)
            ring = torch.from_numpy((yy - cy) ** 2 + (xx - cx) ** 2 <= 6.5 ** 2)
            assert (out[:, ring] - c[:, None]).abs().max() < 0.15
    assert arrived  # some seed moves a small disc into a large place


def test_labels_at_the_fit_size_follow_a_larger_picture():
    image, labels, groups = discs()
    big = torch.nn.functional.interpolate(image[None], scale_factor=2, mode="nearest")[0]
    out = swap_elements(big, labels, groups, seed=3)
    small = swap_elements(image, labels, groups, seed=3)
    for cy, cx in CENTRES:
        assert torch.allclose(out[:, 2 * cy, 2 * cx], small[:, cy, cx], atol=0.02)


def test_footprints_take_the_ground_within_the_margin():
    _, labels, groups = discs()
    place = footprints(labels, np.array([True, False, False, False, False]), margin=2)
    assert place[16, 16 + 8] == 1 and place[16, 16 + 9] == 1  # 1 and 2 px beyond radius 7
    assert place[16, 16 + 11] == -1 and place[32, 32] == -1   # far ground: nobody's


def test_a_background_mass_is_parted_by_the_finer_segments_and_a_backdrop_is_not():
    labels = np.arange(4).repeat(16).reshape(1, 64).repeat(64, 0)  # 4 textons: columns
    groups = np.zeros(4, np.int64)                                  # one mass of everything
    fine = (np.arange(64) >= 32).astype(np.int64)[None].repeat(64, 0)  # two halves
    parted = _finer_in_background(groups, labels, lambda: fine)
    assert parted[0] == parted[1] != parted[2] == parted[3]
    backdrop = np.zeros((64, 64), np.int64)                         # one fine segment
    assert len(set(_finer_in_background(groups, labels, lambda: backdrop))) == 1
    eighths = np.arange(8).repeat(8).reshape(1, 64).repeat(64, 0)  # nothing background-sized
    assert np.array_equal(_finer_in_background(np.arange(8), eighths, lambda: fine), np.arange(8))


def test_an_element_that_does_not_fit_a_place_keeps_its_own():
    """Two squares and two crosses of one area (81 and 80 px, both round): a square never
    takes a cross's place (carried onto it, its outline would have to stretch about 2x along
    the diagonals), while squares trade places with squares and crosses with crosses."""
    from neuraltex.element_outline import outlines
    from neuraltex.element_swap import compatible, fitting_permutation
    from neuraltex.texton_elements import element_shapes

    where = np.zeros((H, W), np.int64)
    for i, (cy, cx) in enumerate(CENTRES):
        if i % 2 == 0:
            where[cy - 4:cy + 5, cx - 4:cx + 5] = i + 1                     # 9 x 9 square
        else:
            where[cy - 6:cy + 6, cx - 2:cx + 2] = i + 1                     # 12 x 4 bar ...
            where[cy - 2:cy + 2, cx - 6:cx + 6] = i + 1                     # ... crossed
    shapes = element_shapes(where, np.arange(5))
    place = np.where(where > 0, where, -1)
    ok = compatible(shapes, outlines(place, shapes.centre, shapes.cov), 1.1)
    assert ok[1, 3] and ok[3, 1] and ok[2, 4] and ok[4, 2]       # like with like
    assert not ok[1, 2] and not ok[2, 1] and not ok[:, 0].any()   # squares / crosses / ground
    for seed in range(6):
        target = fitting_permutation(shapes, place, seed, 1.1)
        # every element that has a partner moves: 1 <-> 3, 2 <-> 4
        assert list(target) == [0, 3, 4, 1, 2]


def test_a_large_element_must_fit_its_place_to_the_pixel_and_a_small_one_in_ratio():
    """A disc and a square of its area — one ratio of outlines at every size, the square's
    corners reaching about 25 % beyond the disc — fit each other's places when small (the
    outlines miss by a pixel or two) but not when large (by about 10 px at a half side of
    40: a swap would tear the pattern around them)."""
    from neuraltex.element_outline import outlines
    from neuraltex.element_swap import compatible
    from neuraltex.texton_elements import element_shapes

    def pair(half):
        size = int(3 * half + 8)
        yy, xx = np.mgrid[0:size, 0:2 * size].astype(float)
        where = np.zeros((size, 2 * size), np.int64)
        c = size / 2
        square = (np.abs(xx - c - size) <= half) & (np.abs(yy - c) <= half)
        where[square] = 2
        where[(xx - c) ** 2 + (yy - c) ** 2 <= square.sum() / np.pi] = 1
        shapes = element_shapes(where, np.arange(3))
        place = np.where(where > 0, where, -1)
        return compatible(shapes, outlines(place, shapes.centre, shapes.cov), 1.1)[1, 2]

    assert pair(5) and not pair(40)


def test_elements_trade_only_with_elements_on_a_ground_like_their_own():
    """Four equal grey discs, two on a dark ground and two on a light one: discs trade
    places with the disc on their own ground only (moved across, each would bring its dark
    or light margin)."""
    from neuraltex.element_swap import swap_and_count

    image, labels, groups = discs()
    image[:, :, :] = 0.6
    image[:, :32] = 0.2                                           # top half dark
    for cy, cx in CENTRES:
        image[:, cy - 3:cy + 4, cx - 3:cx + 4] = 0.9
    marked = image.clone()
    for i, (cy, cx) in enumerate(CENTRES):
        marked[0, cy, cx] = 0.1 * (i + 1)                         # tell the discs apart
    out, moved, total = swap_and_count(marked, labels, groups, seed=0)
    assert (moved, total) == (4, 4)
    for i, (cy, cx) in enumerate(CENTRES):
        came = round(float(out[0, cy, cx]) / 0.1) - 1
        assert came != i and CENTRES[came][0] == cy               # same row: same ground


def test_a_mosaic_of_compact_textons_is_parted_and_coins_and_rings_stay_whole():
    """Three groups of 4 textons each on a 96 x 96 canvas: four separate squares in a row
    with gaps (stones alike in colour: the union is not compact, its pieces are) -> four
    elements; a disc cut into quarters (a coin's fragments: a compact union) and an open ring
    cut into arcs (a rosette: its pieces are not compact) -> one element each."""
    from neuraltex.texton_elements import _parted_mosaics

    labels = np.full((96, 96), 12, np.int64)                        # texton 12: the ground
    for i in range(4):                                               # squares 0..3
        labels[8:18, 8 + 20 * i:18 + 20 * i] = i
    yy, xx = np.mgrid[0:96, 0:96]
    ang = np.arctan2(yy - 60, xx - 24)
    r = np.hypot(yy - 60, xx - 24)
    quarter = ((ang + np.pi) // (np.pi / 2)).astype(np.int64) % 4
    labels[r <= 12] = 4 + quarter[r <= 12]                           # disc: textons 4..7
    r2 = np.hypot(yy - 60, xx - 70)
    ang2 = np.arctan2(yy - 60, xx - 70)
    arc = (r2 >= 9) & (r2 <= 13) & (ang2 < 0.75 * np.pi)              # open ring
    labels[arc] = 8 + ((ang2[arc] + np.pi) // (np.pi / 2)).astype(np.int64) % 4
    groups = np.array([0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3])
    out = _parted_mosaics(groups, labels)
    assert len(set(out[:4])) == 4                                    # the squares parted
    assert len(set(out[4:8])) == 1 and len(set(out[8:12])) == 1      # coin, ring whole
    assert out[4] != out[8] and out[12] not in out[:12]


def test_pairs_the_smoothed_outlines_pass_are_checked_on_the_pixels():
    """A disc and a disc with a slot cut to its centre: their outlines (4 harmonics) agree,
    but carried onto each other they cover under 0.8 of each other's pixels, so with the
    element map at hand the assignment leaves them where they are."""
    from neuraltex.element_outline import outlines
    from neuraltex.element_swap import compatible, fitting_permutation
    from neuraltex.texton_elements import element_shapes

    yy, xx = np.mgrid[0:48, 0:96].astype(float)
    where = np.zeros((48, 96), np.int64)
    where[(xx - 24) ** 2 + (yy - 24) ** 2 <= 100] = 1
    where[((xx - 72) ** 2 + (yy - 24) ** 2 <= 100) & ~((np.abs(yy - 24) <= 2) & (xx > 70))] = 2
    shapes = element_shapes(where, np.arange(3))
    place = np.where(where > 0, where, -1)
    assert compatible(shapes, outlines(place, shapes.centre, shapes.cov), 1.3)[1, 2]
    assert list(fitting_permutation(shapes, place, 0, 1.3)) == [0, 2, 1]
    assert list(fitting_permutation(shapes, place, 0, 1.3, where=where)) == [0, 1, 2]
