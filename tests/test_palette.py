"""Palette transfer between texture files (neuraltex.edit.palette)."""

import numpy as np
import torch

from neuraltex.edit.palette import palette_blend, rank_colours, recolour, texton_colours


def test_textons_take_the_colour_of_the_same_luminance_rank():
    dark, mid, light = (0.1, 0.1, 0.1), (0.5, 0.5, 0.5), (0.9, 0.9, 0.9)
    a = np.array([light, dark])                      # A: a light and a dark texton
    red, yellow = (0.5, 0.0, 0.0), (1.0, 1.0, 0.2)
    b = np.array([yellow, red])
    out = rank_colours(a, np.array([1.0, 1.0]), b, np.array([1.0, 1.0]))
    assert np.allclose(out, [yellow, red])           # dark -> the darker red
    # by area: B is 3/4 red (its middle at quantile 0.375, yellow's at 0.875), so the
    # middle of A's light half (0.75) lies 3/4 of the way from red to yellow
    out = rank_colours(a, np.array([1.0, 1.0]), b, np.array([1.0, 3.0]))
    r, y = np.array(red), np.array(yellow)
    assert np.allclose(out[1], red) and np.allclose(out[0], r + 0.75 * (y - r))
    # three textons of A onto one colour of B: all take it
    three = rank_colours(np.array([dark, mid, light]), np.ones(3), np.array([red]), np.ones(1))
    assert np.allclose(three, red)


def test_recolouring_moves_each_segment_to_its_target_and_keeps_its_detail():
    labels = np.zeros((16, 16), np.int64)
    labels[:, 8:] = 1
    pic = torch.full((3, 16, 16), 0.5)
    pic[:, 4, 2] = 0.7                                # a detail inside segment 0
    colours, _ = texton_colours(pic, labels)
    target = np.array([[0.2, 0.2, 0.2], [0.5, 0.6, 0.7]])
    out = recolour(pic, labels, colours, target, feather=0.0)
    got, _ = texton_colours(out, labels)
    assert np.allclose(got, target, atol=1e-6)
    assert torch.allclose(out[:, 4, 2] - out[:, 4, 3], pic[:, 4, 2] - pic[:, 4, 3])
    soft = recolour(pic, labels, colours, target, feather=1.0)
    assert torch.allclose(soft[:, :, :6], out[:, :, :6]) and torch.allclose(
        soft[:, :, 10:], out[:, :, 10:])               # feathered at the border only
    assert 0.2 < float(soft[0, 0, 7]) < 0.5


def test_texton_colours_follow_labels_at_the_fit_size():
    labels = np.zeros((4, 4), np.int64)
    labels[:, 2:] = 1
    pic = torch.zeros(3, 8, 8)
    pic[0, :, 4:] = 1.0                               # right half red, at twice the size
    colours, area = texton_colours(pic, labels)
    assert np.allclose(colours, [[0, 0, 0], [1, 0, 0]]) and np.allclose(area, [32, 32])


def test_the_blend_runs_from_a_to_b_and_keeps_the_contrast_in_the_middle():
    g = torch.Generator().manual_seed(0)
    a = 0.3 + 0.2 * torch.rand(3, 32, 32, generator=g)      # dark noise
    b = 0.6 + 0.3 * torch.rand(3, 32, 32, generator=g)      # light noise, more contrast
    la = np.arange(64).reshape(8, 8).repeat(4, 0).repeat(4, 1)  # 4 x 4 px textons
    lb = np.zeros((32, 32), np.int64)
    lb[:, 16:] = 1
    assert torch.allclose(palette_blend(a, la, b, lb, 0.0), a, atol=1e-6)
    assert torch.allclose(palette_blend(a, la, b, lb, 1.0), b, atol=1e-6)
    mid = palette_blend(a, la, b, lb, 0.5)
    plain = 0.5 * (a + b)                                   # a cross-fade: washed out
    want = (0.5 * a.var((1, 2)) + 0.5 * b.var((1, 2))).sqrt()
    assert (plain.std((1, 2)) < 0.8 * want).all()
    assert torch.allclose(mid.std((1, 2)), want, rtol=0.1)
    assert torch.allclose(mid.mean((1, 2)), plain.mean((1, 2)), atol=0.02)
    ramp = palette_blend(a, la, b, lb, torch.linspace(0, 1, 32).expand(32, 32))
    assert torch.allclose(ramp[:, :, 0], a[:, :, 0], atol=1e-6)
    assert torch.allclose(ramp[:, :, -1], b[:, :, -1], atol=1e-6)


def test_a_texton_without_pixels_gets_no_weight():
    labels = np.zeros((4, 4), np.int64)
    labels[:, 2:] = 1
    colours, area = texton_colours(torch.full((3, 4, 4), 0.5), labels, count=3)
    assert colours.shape == (3, 3) and area[2] == 0 and np.allclose(colours[:2], 0.5)
    out = rank_colours(colours, area, np.array([[0.2, 0.2, 0.2]]), np.array([1.0]))
    assert np.allclose(out, 0.2)
