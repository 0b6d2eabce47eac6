import json
import math

import pytest
import torch

from conftest import make_textons
from neuraltex.edit.animation import animate, shear_flow, vortex_flow
from neuraltex.edit.interpolate import (
    interpolate,
    interpolate_frames,
    interpolate_spatially,
    match,
)
from neuraltex.edit.texton_edits import (
    apply_edit_list,
    move,
    select_index,
    select_point,
    select_similar,
)
from neuraltex.edit.transfer import transfer, transfer_regions
from neuraltex.edit.vary import effective_mean, lower_triangular_power, vary
from neuraltex.errors import InputError


def _binary(t):
    t.delta = (t.delta > 0.5).float()
    return t


def test_interpolate_endpoints_and_spd():
    a = _binary(make_textons(B=1, K=6, C=3, seed=1))
    b = _binary(make_textons(B=1, K=8, C=3, seed=2))
    t0 = interpolate(a, b, 0.0)
    assert torch.allclose(t0.mu[:, :6], a.mu) and torch.equal(t0.delta[:, :6], a.delta)
    assert (t0.delta[:, 6:] == 0).all()  # padding stays absent
    t1 = interpolate(a, b, 1.0)
    key = lambda m: sorted(map(tuple, m.tolist()))  # noqa: E731
    eff = t1.delta[0] > 0.5
    assert key(t1.mu[0, eff]) == key(b.mu[0, b.delta[0] > 0.5])
    for t in torch.linspace(0, 1, 7).tolist():
        cov = interpolate(a, b, t).cov
        assert (torch.linalg.eigvalsh(cov) > 0).all()
    frames = interpolate_frames(a, b, 5)
    assert len(frames) == 5 and torch.allclose(frames[0].mu[:, :6], a.mu)
    spatial = interpolate_spatially(a, b)
    assert spatial.num_textons == 8


def test_unmatched_textons_fade_in_place():
    a = make_textons(B=1, K=3, C=2, seed=1)
    b = make_textons(B=1, K=5, C=2, seed=2)
    a.delta[:], b.delta[:] = 1, 1
    pa, pb = match(a, b)
    assert torch.equal(pa.mu[:, 3:], pb.mu[:, 3:]) and (pa.delta[:, 3:] == 0).all()
    for t in (0.3, 0.7):  # the two textons of b without partner never move
        assert torch.allclose(interpolate(a, b, t).mu[:, 3:], pb.mu[:, 3:])


def test_vary_identity_and_collapse():
    t = _binary(make_textons(B=2, K=7, C=4, seed=3))
    same = vary(t, 1.0, 1.0)
    assert torch.allclose(same.f, t.f) and torch.allclose(same.cov, t.cov)
    flat = vary(t, 0.0, 0.0)
    assert torch.allclose(flat.f, effective_mean(t.f, t.delta).expand_as(t.f), atol=1e-6)
    assert torch.allclose(flat.cov, effective_mean(t.cov, t.delta).expand_as(t.cov), atol=1e-6)
    more = vary(t, 2.0, 2.0)
    spread = lambda c: torch.linalg.eigvalsh(c).log().std()  # noqa: E731
    assert spread(more.cov) > spread(t.cov)
    assert (torch.linalg.eigvalsh(more.cov) > 0).all()
    t.delta[0] = 0  # a set without effective textons must not break the Cholesky factors
    assert torch.isfinite(vary(t, 0.5, 0.5).cov).all()


def test_vary_can_keep_the_leading_channels():
    t = make_textons(2, 6, 5)
    out = vary(t, 0.3, 1.0, keep=3)
    torch.testing.assert_close(out.f[..., :3], t.f[..., :3])
    torch.testing.assert_close(out.f[..., 3:], vary(t, 0.3, 1.0).f[..., 3:])  # eq. 4.27


def test_lower_triangular_power_matches_matrix_power():
    W = torch.tensor([[[2.0, 0.0], [0.7, 0.5]], [[1.3, 0.0], [-0.4, 1.3]]], dtype=torch.float64)
    assert torch.allclose(lower_triangular_power(W, 2.0), W @ W)
    half = lower_triangular_power(W, 0.5)
    assert torch.allclose(half @ half, W)


def test_transfer_onto_itself_is_identity_and_mean_shift_matches():
    s = _binary(make_textons(B=1, K=6, C=3, seed=4))
    a = _binary(make_textons(B=1, K=9, C=3, seed=5))
    assert torch.allclose(transfer(s, s).f, s.f, atol=1e-6)
    out = transfer(s, a)
    assert torch.allclose(effective_mean(out.f, out.delta), effective_mean(a.f, a.delta),
                          atol=1e-6)
    assert torch.equal(out.mu, s.mu)
    rep = transfer(s, a, mode="replace")
    pool = {tuple(r) for r in a.f[0, a.delta[0] > 0.5].tolist()}
    assert all(tuple(r) in pool for r in rep.f[0, s.delta[0] > 0.5].tolist())
    regions = torch.zeros(8, 8, dtype=torch.long)
    regions[:, 4:] = 1
    out = transfer_regions(s, [s, a], regions, mode="replace")
    right = (s.mu[0, :, 0] >= 0.5) & (s.delta[0] > 0.5)
    assert all(tuple(r) in pool for r in out.f[0, right].tolist())


def test_move_edit_shifts_mu_exactly_and_only_selected():
    t = make_textons(B=1, K=5, C=2, seed=6)
    mask = select_index(t, [1, 3])
    out = move(t, mask, 0.1, -0.05)
    delta = out.mu - t.mu
    assert torch.allclose(delta[0, mask], torch.tensor([0.1, -0.05]).expand(2, 2))
    assert torch.equal(delta[0, ~mask], torch.zeros(3, 2))
    assert torch.allclose(out.cov, t.cov)


def test_selections_and_json_edit_list(tmp_path):
    t = _binary(make_textons(B=1, K=6, C=3, seed=7))
    t.delta[:] = 1
    k = 2
    assert select_point(t, *t.mu[0, k].tolist()).nonzero().flatten().tolist() == [k]
    assert select_similar(t, k, 0.999).nonzero().flatten().tolist() == [k]
    edits = [{"select": {"index": [0]}, "op": "scale", "by": 2.0},
             {"select": {"index": [1]}, "op": "delete"},
             {"select": {"index": [2]}, "op": "duplicate", "offset": [0.1, 0.0]}]
    path = tmp_path / "edits.json"
    path.write_text(json.dumps(edits))
    out = apply_edit_list(t, path)
    assert torch.allclose(out.cov[0, 0], 4 * t.cov[0, 0])
    assert out.num_textons == 7 and out.delta[0, 1] == 0  # deleted = switched off; +1 copy
    assert torch.allclose(out.mu[0, -1], t.mu[0, 2] + torch.tensor([0.1, 0.0]))
    assert out.order[0, -1] == out.order.max()  # the copy is drawn on top
    for bad in ([{"op": "move"}], [{"select": {"index": [0]}, "op": "explode"}],
                [{"select": {"index": [99]}, "op": "delete"}], {"not": "a list"}):
        with pytest.raises(InputError):
            apply_edit_list(t, bad)


def test_animation_frame_zero_and_vortex_period():
    t = make_textons(B=1, K=6, C=2, seed=8)
    frames = animate(t, "shear", frames=4)
    assert torch.allclose(frames[0].mu, t.mu)
    assert not torch.allclose(frames[2].mu, t.mu)
    assert torch.allclose(frames[2].mu[..., 1], t.mu[..., 1])  # shear keeps y
    full = vortex_flow(t, 4.0, omega=2 * math.pi / 4)
    assert torch.allclose(full.mu, t.mu, atol=1e-5)
    assert torch.allclose(full.cov, t.cov, atol=1e-6)
    half = vortex_flow(t, 2.0, omega=2 * math.pi / 4)
    assert not torch.allclose(half.mu, t.mu, atol=1e-3)
    # positions always wrap into the canvas
    far = shear_flow(t, 10.0, velocity=1.0)
    assert (far.mu >= 0).all() and (far.mu <= 1).all()
