"""Elements of a fitted texture (neuraltex.texton_elements): grouping textons into objects, their
shapes, and the reshuffle that moves whole objects."""

import numpy as np
import pytest
import torch

from neuraltex.texton_elements import (
    element_shapes,
    group_textons,
    move_elements,
    reshuffle_elements,
    shape_classes,
    swapped_layout,
)
from neuraltex.textons import Textons

H = W = 48
SQUARES = [(8, 8), (8, 28), (28, 8), (28, 28)]  # top-left corners (y, x) of 12 x 12 squares
COLOURS = [(0.9, 0.2, 0.2), (0.2, 0.9, 0.2), (0.2, 0.2, 0.9), (0.9, 0.9, 0.2)]


def scene():
    """Four coloured squares on grey; every square is two textons (left and right halves),
    the ground is four textons (quadrants). -> image (3, H, W), labels (H, W)."""
    image = torch.full((3, H, W), 0.5)
    labels = np.zeros((H, W), np.int64)
    labels[:, W // 2:] += 1
    labels[H // 2:] += 2  # ground quadrants 0..3
    for i, ((y, x), c) in enumerate(zip(SQUARES, COLOURS, strict=True)):
        image[:, y:y + 12, x:x + 12] = torch.tensor(c)[:, None, None]
        labels[y:y + 12, x:x + 6] = 4 + 2 * i
        labels[y:y + 12, x + 6:x + 12] = 5 + 2 * i
    return image, labels


def textons_of(labels: np.ndarray) -> Textons:
    """One texton per label at its pixels' centroid (short side = 1), small round Gaussians."""
    K = int(labels.max()) + 1
    ys, xs = np.mgrid[0:H, 0:W]
    mu = torch.tensor([[(xs[labels == k].mean() + 0.5) / W, (ys[labels == k].mean() + 0.5) / H]
                       for k in range(K)], dtype=torch.float32)[None]
    cov = torch.eye(2).expand(1, K, 2, 2) * 0.002
    v = torch.tensor([1.0, 0.0]).expand(1, K, 2)
    f = torch.arange(K, dtype=torch.float32)[None, :, None].repeat(1, 1, 3)
    return Textons(mu=mu, cov=cov.clone(), v=v.clone(), f=f, p=torch.ones(1, K),
                   delta=torch.ones(1, K), order=torch.arange(K)[None], canvas=(1.0, 1.0))


def test_the_halves_of_an_object_are_one_element():
    image, labels = scene()
    groups = group_textons(image, labels)
    halves = [(groups[4 + 2 * i], groups[5 + 2 * i]) for i in range(4)]
    assert all(a == b for a, b in halves)
    assert len({a for a, _ in halves}) == 4  # four different squares
    assert len(set(groups[:4])) == 1 and groups[0] not in {a for a, _ in halves}  # the ground


def test_element_shapes_measure_area_centre_sides_and_background():
    image, labels = scene()
    groups = group_textons(image, labels)
    shapes = element_shapes(labels, groups)
    ground = groups[0]
    assert shapes.background[ground] and shapes.sides[ground] == 0b1111
    first = groups[4]
    assert shapes.area[first] == 144 and not shapes.background[first]
    np.testing.assert_allclose(shapes.centre[first], [13.5, 13.5])
    assert shapes.sides[first] == 0 and shapes.elongation[first] == pytest.approx(1.0)
    classes = shape_classes(shapes)
    assert classes[ground] == -1
    assert len({classes[groups[4 + 2 * i]] for i in range(4)}) == 1  # alike: one class


def test_moving_elements_carries_every_texton_of_an_object_by_the_same_offset():
    image, labels = scene()
    groups = group_textons(image, labels)
    t = textons_of(labels)
    moved = move_elements(t, labels, groups, seed=3)
    shift = (moved.mu - t.mu)[0]
    assert torch.equal(shift[:4], torch.zeros(4, 2))  # the ground stays
    for i in range(4):
        torch.testing.assert_close(shift[4 + 2 * i], shift[5 + 2 * i])  # halves together
    # the squares trade places: the set of their centres is the same, not every one stays
    before = {tuple(np.round(t.mu[0, 4 + 2 * i].tolist(), 4)) for i in range(4)}
    after = {tuple(np.round(moved.mu[0, 4 + 2 * i].tolist(), 4)) for i in range(4)}
    assert before == after and shift[4:].abs().sum() > 0
    assert torch.equal(moved.f, t.f)  # appearance travels with the geometry
    again = move_elements(t, labels, groups, seed=3)
    assert torch.equal(again.mu, moved.mu)


def test_objects_cut_by_the_border_trade_only_with_objects_cut_alike():
    image, labels = scene()
    image[:, 8:20, 0:6] = 0.1  # a fifth square, cut by the left border
    labels[8:20, 0:6] = 12
    groups = group_textons(image, labels)
    shapes = element_shapes(labels, groups)
    cut = groups[12]
    assert shapes.sides[cut] == 0b0001
    classes = shape_classes(shapes)
    assert (classes == classes[cut]).sum() == 1
    for seed in range(5):
        moved = move_elements(textons_of(labels), labels, groups, seed=seed)
        assert torch.equal(moved.mu[0, 12], textons_of(labels).mu[0, 12])


def test_reshuffle_by_elements_draws_the_ground_behind_and_keeps_objects_whole():
    image, labels = scene()
    groups = group_textons(image, labels)
    t = textons_of(labels)
    out = reshuffle_elements(t, labels, groups, seed=1)
    assert (out.order[0, :4] < out.order[0, 4:].min()).all()
    assert torch.equal(out.f[0, 4:], t.f[0, 4:])  # objects keep their own features
    assert sorted(out.f[0, :4, 0].tolist()) == [0, 1, 2, 3]  # ground trades among itself


def test_a_rim_around_an_object_joins_it_but_a_neighbour_does_not():
    """A coin's rim is a segment of its own at any scale; it lies within a quarter radius of
    the face it surrounds, so it joins the face's element. A whole object beside it does not."""
    n = 64
    yy, xx = np.mgrid[0:n, 0:n]
    r = np.hypot(yy - 24, xx - 24)
    image = torch.full((3, n, n), 0.2)
    labels = np.zeros((n, n), np.int64)                     # ground
    face, rim = r < 10, (r >= 10) & (r < 12.5)
    near = (np.abs(yy - 24) < 6) & (np.abs(xx - 50) < 6)    # a square 14 px to the right
    for k, (m, c) in enumerate([(face, 0.9), (rim, 0.5), (near, 0.9)], start=1):
        image[:, torch.from_numpy(m)] = c
        labels[m] = k
    groups = group_textons(image, labels)
    assert groups[1] == groups[2]          # rim with face
    assert groups[3] != groups[1]          # the neighbour is its own element
    assert groups[0] not in (groups[1], groups[3])


def test_shape_classes_group_areas_within_the_ratio_without_bin_edges():
    from neuraltex.texton_elements import ElementShapes

    area = np.array([100.0, 101.0, 108.0, 130.0, 5000.0])
    shapes = ElementShapes(area=area, centre=np.zeros((5, 2)), elongation=np.ones(5),
                           angle=np.zeros(5), sides=np.zeros(5, np.int64),
                           background=np.array([False] * 4 + [True]),
                           cov=np.tile(np.eye(2), (5, 1, 1)))
    c = shape_classes(shapes, size_ratio=1.1)
    assert c[0] == c[1] == c[2]            # 100, 101 and 108: within 1.1 of 100
    assert c[3] != c[0] and c[4] == -1     # 130 is not; the background never trades
    assert shape_classes(shapes, size_ratio=1.5)[3] == c[0]


def test_a_swapped_layout_pastes_the_moved_objects_and_masks_what_nobody_covers():
    image, labels = scene()
    image[:, 28:40, 8:20] = torch.tensor([0.9, 0.2, 0.9])[:, None, None]
    image[:, 30:34, 30:34] = 0.0       # a dark spot inside the fourth square
    groups = group_textons(image, labels)
    t = textons_of(labels)
    moved, target, known = swapped_layout(image, labels, groups, t, seed=3)
    shift = (moved.mu - t.mu)[0] * W   # pixels
    assert torch.equal(shift[:4], torch.zeros(4, 2)) and shift.abs().sum() > 0
    torch.testing.assert_close(shift, shift.round(), atol=1e-4, rtol=0)  # whole pixels
    for i, (y, x) in enumerate(SQUARES):
        dx, dy = shift[4 + 2 * i].round().long().tolist()
        torch.testing.assert_close(target[:, y + dy:y + dy + 12, x + dx:x + dx + 12],
                                   image[:, y:y + 12, x:x + 12])
    assert known.min() == 1            # equal squares: every left place is filled again
    assert torch.equal(target[:, :8], image[:, :8])  # the ground stays as it was
    # one square a column narrower (132 px: the same class at 1.1): where it lands, the
    # column of the wider square it replaces is unknown
    labels[28:40, 19] = 2
    image[:, 28:40, 19] = 0.5
    groups = group_textons(image, labels)
    for seed in range(20):
        moved, _, known = swapped_layout(image, labels, groups, textons_of(labels), seed=seed)
        if (moved.mu - textons_of(labels).mu)[0, labels[30, 10]].abs().sum() > 0:
            break
    assert (known == 0).sum() == 12 and known.max() == 1
