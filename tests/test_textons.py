import json
import math
import pickle

import pytest
import torch

from conftest import make_textons
from neuraltex.textons import Textons
from neuraltex.textons_file import TextonFileError, load_textons, save_textons


def _same(a: Textons, b: Textons) -> None:
    for k in ("mu", "cov", "v", "f", "p", "delta", "order"):
        x, y = getattr(a, k), getattr(b, k)
        assert x.dtype == y.dtype and torch.equal(x, y), k
    assert a.canvas == b.canvas


def test_shape_validation():
    t = make_textons(B=1, K=3, C=2)
    with pytest.raises(ValueError, match="cov"):
        Textons(mu=t.mu, cov=t.cov[..., 0], v=t.v, f=t.f, p=t.p, delta=t.delta, order=t.order)


def test_filter_compacts_and_pads(textons):
    keep = torch.tensor([[True, False, True, False, False], [False, False, False, True, False]])
    out = textons.filter(keep)
    assert out.num_textons == 2
    assert torch.equal(out.mu[0], textons.mu[0, [0, 2]])
    assert torch.equal(out.mu[1, 0], textons.mu[1, 3])
    assert out.delta[1, 1] == 0 and out.p[1, 1] == 0  # padding is absent
    assert out.order[1, 1] < out.order[1, 0]          # and drawn behind


def test_filter_of_one_set_matches_the_batched_path(textons):
    keep = torch.tensor([[True, False, True, False, True], [False, True, False, True, True]])
    batched = textons.filter(keep)  # B = 2: the general path
    for b in range(2):
        _same(textons[b].filter(keep[b:b + 1]), batched[b])
    assert textons[0].filter(torch.zeros(1, 5, dtype=torch.bool)).num_textons == 0


def test_existing_keeps_effective_only(textons):
    out = textons.existing()
    assert torch.equal(out.num_effective(), textons.num_effective())
    for b in range(textons.batch_size):
        kept = textons.f[b, textons.delta[b] > 0.5]
        assert torch.equal(out.f[b, : len(kept)], kept)


def test_index_and_region(textons):
    out = textons.index(torch.tensor([4, 0]))
    assert torch.equal(out.cov[:, 0], textons.cov[:, 4])
    inside = textons.in_region((0.0, 0.0, 0.5, 0.5))
    expected = (textons.mu[..., 0] < 0.5) & (textons.mu[..., 1] < 0.5)
    assert torch.equal(inside, expected)
    mask = torch.zeros(10, 10, dtype=torch.bool)
    mask[:5, :5] = True  # top-left quarter of the canvas
    assert torch.equal(textons.in_region(mask), expected)
    with pytest.raises(IndexError):
        textons.index(torch.tensor([5]))


def test_cat_puts_later_sets_in_front(textons):
    both = Textons.cat([textons, textons], dim=1)
    assert both.num_textons == 10
    assert both.order[:, 5:].min() > both.order[:, :5].max()
    batch = Textons.cat([textons, textons.index(torch.tensor([0, 1]))], dim=0)
    assert batch.batch_size == 4 and batch.num_textons == 5
    assert (batch.delta[2:, 2:] == 0).all()


def test_affine_transforms_mu_cov_v_consistently(textons):
    A = torch.tensor([[1.2, 0.3], [-0.4, 0.8]])
    t = torch.tensor([0.1, -0.2])
    out = textons.affine(A, t)
    assert torch.allclose(out.mu, textons.mu @ A.T + t, atol=1e-6)
    assert torch.allclose(out.cov, A @ textons.cov @ A.T, atol=1e-6)
    v = textons.v @ A.T
    assert torch.allclose(out.v, v / v.norm(dim=-1, keepdim=True), atol=1e-6)
    assert torch.equal(out.f, textons.f) and torch.equal(out.order, textons.order)


def test_affine_keeps_float32_geometry_under_bfloat16_autocast(textons):
    """The equivariance term transforms textons inside the trainer's autocast (trainer.amp);
    their geometry stays float32 and equal to the plain transform (a bfloat16 covariance
    lost its determinant and the splatting's inverse gave non-finite gradients)."""
    A = torch.tensor([[1.2, 0.3], [-0.4, 0.8]])
    plain = textons.affine(A, (0.1, -0.2))
    with torch.autocast("cpu", dtype=torch.bfloat16):
        mixed = textons.affine(A, (0.1, -0.2))
    for name in ("mu", "cov", "v"):
        got, want = getattr(mixed, name), getattr(plain, name)
        assert got.dtype == torch.float32 and torch.allclose(got, want, atol=1e-6), name

def test_rotate_scale_translate(textons):
    r = textons.rotate(90, center=(0.5, 0.5))
    # Counter-clockwise on screen with y down: (x, y) -> (cx + (y - cy), cy - (x - cx)).
    x, y = textons.mu[..., 0], textons.mu[..., 1]
    assert torch.allclose(r.mu, torch.stack([y, 1 - x], -1), atol=1e-6)
    # Eigenvalues (shape) survive a rotation; scale multiplies them by s^2.
    ev = torch.linalg.eigvalsh(textons.cov)
    assert torch.allclose(torch.linalg.eigvalsh(r.cov), ev, atol=1e-6)
    assert torch.allclose(torch.linalg.eigvalsh(textons.scale(3.0).cov), 9 * ev, atol=1e-5)
    assert torch.allclose(textons.translate(0.1, 0.2).mu, textons.mu + torch.tensor([0.1, 0.2]))
    full = textons.rotate(360)
    assert torch.allclose(full.mu, textons.mu, atol=1e-6)


def test_to_keeps_order_integer(textons):
    d = textons.to(dtype=torch.float64)
    assert d.mu.dtype == torch.float64 and d.order.dtype == torch.int64


@pytest.mark.parametrize("suffix", [".pt", ".json"])
def test_save_load_round_trip_is_exact(tmp_path, textons, suffix):
    textons.canvas = (1.5, 1.0)
    path = tmp_path / f"t{suffix}"
    save_textons(textons, path)
    _same(load_textons(path), textons)
    assert not list(tmp_path.glob(".*tmp*"))  # no temp files left behind


def test_json_is_human_readable_and_versioned(tmp_path, textons):
    path = tmp_path / "t.json"
    save_textons(textons, path)
    data = json.loads(path.read_text())
    assert data["format"] == "neuraltex.textons" and data["version"] == 1
    first = data["sets"][0]["textons"][0]
    assert set(first) == {"p", "delta", "mu", "cov", "v", "order", "f"}


def _json_edit(tmp_path, textons, edit):
    path = tmp_path / "t.json"
    save_textons(textons, path)
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.update(version=2), "version"),
    (lambda d: d.update(format="other"), "not a neuraltex.textons"),
    (lambda d: d["sets"][0]["textons"][0].update(p=1.5), "p"),
    (lambda d: d["sets"][0]["textons"][0].update(cov=[[1, 0], [0, -1]]), "positive definite"),
    (lambda d: d["sets"][0]["textons"][0].update(cov=[[1, 0.5], [0, 1]]), "symmetric"),
    (lambda d: d["sets"][0]["textons"][0].update(v=[3, 0]), "unit"),
    (lambda d: d["sets"][0]["textons"][0].update(mu=[float("nan"), 0]), "NaN"),
    (lambda d: d["sets"][0]["textons"][0].pop("f"), "needs 'f'"),
    (lambda d: d["sets"][0]["textons"][0].update(f=[1.0]), "malformed"),
    (lambda d: d["sets"][0]["textons"][0].update(order=0.5), "integers"),
])
def test_tampered_json_is_rejected(tmp_path, textons, edit, message):
    path = _json_edit(tmp_path, textons, edit)
    with pytest.raises(TextonFileError, match=message):
        load_textons(path)


class _Evil:
    def __reduce__(self):
        return (print, ("pwned",))


def test_pickle_payload_in_pt_is_refused(tmp_path, textons):
    path = tmp_path / "evil.pt"
    save_textons(textons, path)
    data = torch.load(path, weights_only=True)
    data["extra"] = _Evil()
    torch.save(data, path)  # a zip checkpoint whose pickle calls print() when unpickled
    with pytest.raises(TextonFileError, match="not a loadable"):
        load_textons(path)
    with open(path, "wb") as fh:  # a bare pickle stream
        pickle.dump(data, fh, protocol=2)
    with pytest.raises(TextonFileError, match="not a loadable"):
        load_textons(path)


def test_truncated_and_wrong_version_pt(tmp_path, textons):
    path = tmp_path / "t.pt"
    save_textons(textons, path)
    blob = path.read_bytes()
    path.write_bytes(blob[: len(blob) // 2])
    with pytest.raises(TextonFileError):
        load_textons(path)
    save_textons(textons, path)
    data = torch.load(path, weights_only=True)
    data["version"] = 99
    torch.save(data, path)
    with pytest.raises(TextonFileError, match="version 99"):
        load_textons(path)
    data["version"] = 1
    data["cov"] = data["cov"][..., 0]
    torch.save(data, path)
    with pytest.raises(TextonFileError, match="cov"):
        load_textons(path)


def test_missing_file_and_bad_suffix(tmp_path, textons):
    with pytest.raises(TextonFileError, match="no such file"):
        load_textons(tmp_path / "nope.json")
    with pytest.raises(Exception, match="json or .pt"):
        save_textons(textons, tmp_path / "t.txt")


def test_rotation_keeps_v_unit(textons):
    r = textons.rotate(33.0)
    assert torch.allclose(r.v.norm(dim=-1), torch.ones(2, 5))
    ang = math.radians(33.0)
    # v turns with the textons: the angle between v and the x axis changes by -33 deg
    # (counter-clockwise on screen is negative in y-down coordinates).
    before = torch.atan2(textons.v[..., 1], textons.v[..., 0])
    after = torch.atan2(r.v[..., 1], r.v[..., 0])
    diff = torch.remainder(after - before + ang + math.pi, 2 * math.pi) - math.pi
    assert diff.abs().max() < 1e-5


def test_written_files_get_normal_permissions(tmp_path, textons):
    import os

    path = tmp_path / "t.json"
    save_textons(textons, path)
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask
