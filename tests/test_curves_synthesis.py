"""Curve synthesis end to end: structure, domain constraint, autocomplete, baselines."""

from pathlib import Path

import numpy as np
import pytest
import torch

from cvt.curves.autocomplete import autocomplete, region_around
from cvt.curves.baselines import run_curves
from cvt.curves.reconstruction import curves_svg
from cvt.curves.sampling import exemplar_graph
from cvt.curves.stats import compare, graph_stats
from cvt.curves.strokes import curve_exemplar, load_curves
from cvt.curves.synthesis import CurveConfig, synthesize_curves
from cvt.svg import parse_svg

EX = Path(__file__).resolve().parents[1] / "cvt" / "exemplars" / "curves"
FAST = CurveConfig(levels=2, iterations=3)


@pytest.fixture(scope="module")
def waves():
    return load_curves(EX / "waves.svg")


def test_shipped_curve_exemplars_load():
    names = sorted(p.stem for p in EX.glob("*.svg"))
    assert len(names) >= 10
    for n in names:
        assert len(load_curves(EX / f"{n}.svg").strokes) > 0


def test_synthesis_keeps_the_structure(waves):
    res = synthesize_curves(waves, (200, 200), FAST)
    g = res.graph
    assert len(g) > 200 and len(g.edges) > 0.8 * len(g)
    deg = torch.bincount(g.degree(), minlength=4)
    assert deg[2] > 0.8 * len(g)  # waves are lines: almost all samples inside a line
    assert int((g.degree() >= 3).sum()) < 0.02 * len(g)
    svg = curves_svg(waves.exemplar, waves.element_centers(), g, res.size)
    delta = res.delta
    out = graph_stats(exemplar_graph(curve_exemplar(parse_svg(svg.encode())), delta),
                      (0, 0, 200, 200), delta)
    ref = graph_stats(res.inputs[-1], waves.box, delta)
    assert compare(out, ref)["degree_tv"] < 0.1


def test_domain_constraint_circle(waves):
    def inside(p):
        return (p - torch.tensor([150.0, 150.0]).double()).norm(dim=1) <= 100

    res = synthesize_curves(waves, (300, 300), FAST, inside=inside)
    r = (res.graph.pos - torch.tensor([150.0, 150.0]).double()).norm(dim=1)
    assert len(res.graph) > 100 and float(r.max()) <= 100 + 1e-6
    assert float(r.min()) < 30  # filled, not just the rim


def test_autocomplete_keeps_the_drawing_and_continues_it(waves):
    drawn = curve_exemplar(parse_svg(
        b'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 200 200"><path d="M0 40 '
        b'C 50 30, 80 50, 120 40" fill="none" stroke="#1d3557" stroke-width="2"/></svg>'))
    box = region_around(drawn, 50)
    res = autocomplete(waves, drawn, box, CurveConfig(levels=2, iterations=4))
    fixed = res.graph.select(torch.arange(res.n_fixed))
    assert res.n_fixed > 10 and len(res.graph) > res.n_fixed + 20
    assert len(fixed.edges) == res.n_fixed - 1  # the drawn stroke is intact
    assert np.allclose(fixed.pos[0].numpy(), [0, 40])
    new = res.predicted()
    x0, y0, x1, y1 = box
    p = new.pos[len(new) - (len(res.graph) - res.n_fixed):]
    assert bool(((p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)).all())
    assert res.seconds < 10


def test_baselines_run(waves):
    for method in ("no-connectivity", "random"):
        g, delta = run_curves(method, waves, (200, 200), FAST)
        assert len(g) > 100 and delta > 0


def test_eval_stages_before_and_after_the_end_repair(waves):
    from cvt.curves.baselines import run_staged

    run = run_staged("no-connectivity", waves, (200, 200), FAST)
    assert run.delta > 0 and len(run.final) <= len(run.raw)  # the finish only prunes
    inner = (run.raw.pos > 8).all(1) & (run.raw.pos < 192).all(1)
    raw_ends = int(((run.raw.degree() == 1) & inner).sum())
    inner = (run.final.pos > 8).all(1) & (run.final.pos < 192).all(1)
    assert int(((run.final.degree() == 1) & inner).sum()) <= raw_ends
    # the baseline: reconnected and faired only -- no sample pruned, no edge added
    assert len(run.plain) == len(run.raw) and torch.equal(run.plain.edges, run.raw.edges)
    assert not torch.equal(run.plain.pos, run.raw.pos)  # faired


def test_our_synthesis_resolves_unbacked_ends_itself(waves):
    """Waves have no ends: with the end resolution (cvt.curves.ends) the synthesis leaves
    fewer interior ends than without it (end_reach 0, no fragment removal)."""
    from dataclasses import replace

    def ends(cfg):
        g = synthesize_curves(waves, (200, 200), cfg).graph
        inner = (g.pos > 8).all(1) & (g.pos < 192).all(1)
        return int(((g.degree() == 1) & inner).sum())

    off = ends(replace(FAST, end_reach=0.0, fragment=0, init_candidates=1))
    assert ends(FAST) < off


def test_coastline_strokes_run_on_instead_of_ending():
    """A coastline crop has no stroke ends inside: unwanted ends grow and join farther
    (CurveConfig.grow, free_reach); without them more strokes stop inside."""
    from dataclasses import replace

    cx = load_curves(Path(__file__).resolve().parents[1] / "data" / "real_curves" / "coastline.svg")
    w, h = cx.exemplar.viewbox[2:]

    def ends(cfg):
        g = synthesize_curves(cx, (w, h), cfg).graph
        m = 0.05 * w
        inner = ((g.pos[:, 0] > m) & (g.pos[:, 0] < w - m) & (g.pos[:, 1] > m)
                 & (g.pos[:, 1] < h - m) & (g.kind < 0))
        return int(((g.degree() == 1) & inner).sum())

    assert ends(FAST) < ends(replace(FAST, grow=0.5, free_reach=4.0))


def test_a_finer_level_starts_from_the_coarser_levels_matches():
    from cvt.curves.graph import StrokeStyle
    from cvt.curves.sampling import stroke_graph
    from cvt.curves.strokes import Stroke
    from cvt.curves.synthesis import carry_sources, upsample

    style = [StrokeStyle("#000000", 1.0)]
    arc = np.array([[10.0 + t, 50 + 20 * np.sin(t / 15)] for t in np.linspace(0, 80, 60)])
    inp_old, inp_new = (stroke_graph([Stroke(arc, False, 0)], style, d) for d in (4.0, 2.0))
    shift = torch.tensor([7.0, -3.0], dtype=torch.float64)
    old = inp_old.with_(pos=inp_old.pos + shift, source=torch.arange(len(inp_old)))
    new = carry_sources(old, upsample(old, 2.0), inp_old, inp_new)
    assert (new.source >= 0).all()
    err = (inp_new.pos[new.source] + shift - new.pos).norm(dim=1)
    assert float(err.max()) < 2.0  # each starts on the input sample it copies
    assert (upsample(old, 2.0).source < 0).all()  # without it: random guesses
