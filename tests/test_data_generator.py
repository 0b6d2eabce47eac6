import numpy as np
import pytest

from neuraltex.data import EASY, FAMILIES, FAMILY_NAMES, HARD, generate
from neuraltex.data.canvas import Canvas
from neuraltex.data.generator import mask_centers, relabel
from neuraltex.data.noise import value_noise
from neuraltex.errors import InputError


def test_default_stream_draws_every_family_and_says_which():
    seen: dict[str, bool] = {}  # family -> hard, as the samples report it
    for i in range(300):
        s = generate(i, 0, 16)
        seen[s.family] = s.hard
        if len(seen) == len(FAMILY_NAMES):
            break
    assert set(seen) == set(FAMILY_NAMES)  # uniform over families: every one turns up
    assert {n for n, hard in seen.items() if hard} == set(HARD) and set(EASY) and set(HARD)
    forced = generate(0, 0, 16, family=HARD[0])
    assert forced.family == HARD[0] and forced.hard and FAMILIES[HARD[0]].description


@pytest.mark.parametrize("family", FAMILY_NAMES)
def test_every_family_renders(family):
    s = generate(1, 0, (40, 48), family=family)
    assert s.image.shape == (40, 48, 3) and s.image.dtype == np.float32
    assert s.mask.shape == (40, 48) and s.mask.dtype == np.int32
    assert 0.0 <= s.image.min() and s.image.max() <= 1.0
    ids = np.unique(s.mask)
    # ids are 0 (optional) plus exactly 1..K, and K is the count
    assert s.count >= 3
    assert set(ids[ids > 0]) == set(range(1, s.count + 1))
    assert s.family == family and s.hard == FAMILIES[family].hard
    assert s.centers.shape == (s.count, 2)
    assert s.image.std() > 0.01  # not a blank image


def test_deterministic_and_seed_dependent():
    a, b = generate(7, 3, 32), generate(7, 3, 32)
    np.testing.assert_array_equal(a.image, b.image)
    np.testing.assert_array_equal(a.mask, b.mask)
    c = generate(8, 3, 32)
    assert not np.array_equal(a.image, c.image)


@pytest.mark.parametrize("family", ["discs", "stones", "leaves"])
def test_resolution_independent(family):
    lo, hi = generate(2, 0, 32, family=family), generate(2, 0, 64, family=family)
    down = hi.image.reshape(32, 2, 32, 2, 3).mean((1, 3))
    assert np.abs(down - lo.image).mean() < 0.03
    assert abs(lo.count - hi.count) <= max(2, 0.15 * hi.count)


def test_bad_input():
    with pytest.raises(InputError):
        generate(0, 0, 4)
    with pytest.raises(InputError):
        generate(0, 0, 32, family="nope")
    with pytest.raises(InputError):
        generate(-1, 0, 32)


def test_relabel_keeps_order():
    ids = np.array([[0, 9, 9], [4, 4, 0], [7, 0, 9]])
    np.testing.assert_array_equal(relabel(ids), [[0, 3, 3], [1, 1, 0], [2, 0, 3]])
    sparse = np.array([[10**9, 5], [0, 5]])  # far apart ids take the slow path
    np.testing.assert_array_equal(relabel(sparse), [[2, 1], [0, 1]])
    np.testing.assert_array_equal(relabel(np.array([[3, 3], [8, 3]])), [[1, 1], [2, 1]])


def test_mask_centers_hand_case():
    mask = np.zeros((4, 4), np.int32)
    mask[0:2, 0:2] = 1  # centre at pixel (0.5, 0.5) -> ((0.5 + 0.5) / 4) = 0.25
    mask[3, 3] = 2  # pixel centre (3.5 / 4, 3.5 / 4)
    np.testing.assert_allclose(mask_centers(mask), [[0.25, 0.25], [0.875, 0.875]])


def _disc(cx, cy, r, color):
    return dict(kind="ellipse", cx=np.array([cx]), cy=np.array([cy]), r=np.array([r]),
                color=np.array([color], np.float32))


def test_canvas_occlusion_and_antialiasing():
    canvas = Canvas(np.zeros((32, 32, 3), np.float32))
    canvas.paint(_disc(0.4, 0.5, 0.25, [1, 0, 0]))
    canvas.paint(_disc(0.6, 0.5, 0.25, [0, 1, 0]))
    assert canvas.ids[16, 16] == 2  # overlap belongs to the occluder (painted last)
    assert canvas.ids[16, 6] == 1 and canvas.ids[0, 0] == 0
    np.testing.assert_allclose(canvas.rgb[16, 16], [0, 1, 0], atol=1e-6)
    # anti-aliased: some edge pixels are partial mixtures
    red = canvas.rgb[..., 0]
    assert ((red > 0.05) & (red < 0.95)).sum() > 5


def test_batched_paint_matches_one_by_one():
    rng = np.random.default_rng(0)
    k = 12
    t = dict(kind=np.where(rng.uniform(size=k) < 0.5, "star", "box"), cx=rng.uniform(0, 1, k),
             cy=rng.uniform(0, 1, k), r=rng.uniform(0.05, 0.2, k), aspect=rng.uniform(1, 2, k),
             angle=rng.uniform(0, 3, k), color=rng.uniform(0, 1, (k, 3)), n=5, star=0.4,
             outline=np.tile([0.01, 0.3], (k, 1)), shadow=(0.01, 0.01, 0.3))
    a, b = Canvas(np.zeros((40, 40, 3), np.float32)), Canvas(np.zeros((40, 40, 3), np.float32))
    a.paint(t, chunk=8)
    for i in range(k):  # plain reference: one texton at a time, its own window
        b.paint({n: (v[i:i + 1] if isinstance(v, np.ndarray) else v) for n, v in t.items()})
    np.testing.assert_allclose(a.rgb, b.rgb, atol=1e-5)
    np.testing.assert_array_equal(a.ids, b.ids)


def test_noise_separable_path_matches_general():
    x = ((np.arange(20) + 0.5) / 20).astype(np.float32)[None, :]
    y = ((np.arange(16) + 0.5) / 20).astype(np.float32)[:, None]
    fast = value_noise(np.random.default_rng(1), x, y, 5.0, (1.0, 0.8))
    X, Y = np.broadcast_arrays(x, y)
    slow = value_noise(np.random.default_rng(1), X, Y, 5.0, (1.0, 0.8))
    np.testing.assert_allclose(fast, slow, atol=1e-6)
    assert -1.0 <= fast.min() and fast.max() <= 1.0 and fast.std() > 0.05
