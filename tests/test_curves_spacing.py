"""Sampling distances adapted to the exemplar's stroke detail (cvt.curves.spacing)."""

from dataclasses import replace

import numpy as np

from cvt.curves.graph import StrokeStyle
from cvt.curves.spacing import curve_levels, detail_scale
from cvt.curves.strokes import CurveExemplar, Stroke, curve_exemplar
from cvt.curves.synthesis import CurveConfig
from cvt.svg import parse_svg

SVG = b'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 180 180"></svg>'


def _exemplar(points) -> CurveExemplar:
    cx = curve_exemplar(parse_svg(SVG.replace(b"></svg>", b'><path d="M0 90 L180 90" '
                                                     b'stroke="black" fill="none"/></svg>')))
    return replace(cx, strokes=[Stroke(np.asarray(points, float), False, 0)],
                   styles=[StrokeStyle("#000000", 1.0)])


def test_fine_wiggles_halve_the_spacings_smooth_strokes_keep_them():
    x = np.linspace(0, 180, 721)
    wiggly = _exemplar(np.c_[x, 90 + 3 * np.sin(x * 2 * np.pi / 7)])  # period 7 < 2 delta
    smooth = _exemplar(np.c_[x, 90 + 20 * np.sin(x * 2 * np.pi / 90)])
    delta = 5.0  # 180 / 36
    assert detail_scale(smooth, delta, 1.0, 2, 3000) == 1.0
    assert detail_scale(wiggly, delta, 1.0, 2, 3000) < 1.0
    assert detail_scale(wiggly, delta, 1.0, 2, 50) == 1.0  # too many samples: kept
    cfg = CurveConfig()
    fine, plain = curve_levels(wiggly, cfg), curve_levels(wiggly, replace(cfg, detail_turn=0.0))
    assert fine[-1].delta < plain[-1].delta and plain[-1].delta == cfg.level(180, 2).delta
    assert fine[0].radius == plain[0].radius  # the neighbourhoods keep their extent
