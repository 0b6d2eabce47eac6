import math

import numpy as np
import torch

from conftest import single
from neuraltex.overlay import draw_overlay, ellipses_svg
from neuraltex.splatting import splat
from neuraltex.textons import ellipse_axes, ellipse_points


def test_ellipse_points_lie_on_the_m1_level_set():
    cov = torch.tensor([[0.02, 0.006], [0.006, 0.005]], dtype=torch.float64)
    t = single((0.5, 0.5), cov.tolist())
    pts = ellipse_points(t.mu[0, 0].float(), t.cov[0, 0].float())
    d = pts.double() - 0.5
    m2 = (d @ torch.linalg.inv(cov) * d).sum(-1)
    assert torch.allclose(m2, torch.ones_like(m2), atol=1e-4)
    a, b, _ = ellipse_axes(cov)
    assert a >= b and math.isclose(float(a * b) ** 2, float(torch.det(cov)), rel_tol=1e-4)


def test_overlay_draws_on_segments_and_svg_lists_effective_textons():
    t = single((0.5, 0.5), [[0.02, 0.0], [0.0, 0.01]])
    image = splat(t.to(dtype=torch.float32), (32, 32)).max_opacity[0].expand(3, -1, -1)
    masks = torch.stack([image[0] > 0.3, image[0] <= 0.3]).float()
    pic = draw_overlay(image, t.to(dtype=torch.float32), masks, scale=2)
    assert pic.size == (64, 64)
    arr = torch.from_numpy(np.asarray(pic).copy())
    assert (arr[32, 32] != (image[:, 16, 16] * 255).round().int()).any()  # tinted centre
    svg = ellipses_svg(t.to(dtype=torch.float32), 32, 32)
    assert svg.count("<ellipse") == 1 and 'cx="16.000"' in svg
