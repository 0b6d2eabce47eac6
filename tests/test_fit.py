"""Tuning to one texture (neuraltex.fit), its masks (segmenters), texton kinds, the tuned
decoder and texture files, on tiny images with the shipped default model."""

import math

import numpy as np
import pytest
import torch

from neuraltex.fit import FitSettings, dihedral, fit_texture, ground_labels, initial_textons
from neuraltex.model import DEFAULT_MODEL, build_model, load_model
from neuraltex.reshuffle import reshuffle
from neuraltex.segmenters import (
    felzenszwalb_labels,
    kmeans_labels,
    refine_to_image,
    segment_labels,
    soft_masks,
)
from neuraltex.texton_kinds import texton_kinds
from neuraltex.textons import Textons
from neuraltex.texture_file import TextureFileError, load_texture, model_id, save_texture
from neuraltex.tuned_decoder import tuned_model, with_offsets

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def model():
    return load_model(DEFAULT_MODEL)


def discs(size: int = 32) -> torch.Tensor:
    """Dark discs on a light ground, (3, size, size)."""
    y, x = torch.meshgrid(torch.arange(size), torch.arange(size), indexing="ij")
    img = torch.ones(3, size, size) * torch.tensor([0.9, 0.8, 0.6])[:, None, None]
    for cy, cx in ((8, 8), (8, 24), (24, 8), (24, 24)):
        inside = (y - cy) ** 2 + (x - cx) ** 2 < 25
        img[:, inside] = torch.tensor([0.2, 0.1, 0.3])[:, None]
    return img


def test_felzenszwalb_respects_the_segment_cap():
    rng = np.random.default_rng(0)
    noise = rng.random((64, 64, 3))
    assert felzenszwalb_labels(noise, 10).max() + 1 <= 10
    labels = felzenszwalb_labels(discs(32).permute(1, 2, 0).double().numpy(), 400)
    centres = {labels[8, 8], labels[8, 24], labels[24, 8], labels[24, 24]}
    assert len(centres) == 4 and labels[0, 0] not in centres  # four discs on the ground


def test_kmeans_segments_are_connected_and_capped():
    from skimage.measure import label

    labels = kmeans_labels(discs(32).permute(1, 2, 0).double().numpy(), 400)
    assert labels.max() + 1 == 5  # two colours, five connected regions
    for k in range(5):
        assert label(labels == k).max() == 1
    assert kmeans_labels(np.random.default_rng(1).random((32, 32, 3)), 6).max() + 1 <= 6


def test_refinement_snaps_coarse_labels_to_image_edges():
    img = torch.zeros(3, 32, 32)
    img[:, :, 16:] = 1.0  # an edge at column 16
    coarse = np.zeros((32, 32), np.int64)
    coarse[:, 19:] = 1  # a coarse boundary 3 px off
    fine = refine_to_image(coarse, img.permute(1, 2, 0).double().numpy(), 16)
    assert (fine[:, :16] == 0).all() and (fine[:, 16:] == 1).all()


def test_soft_masks_sum_to_one_and_keep_their_labels():
    labels = np.array([[0, 0, 1], [2, 2, 1], [2, 2, 1]])
    m = soft_masks(labels)
    assert m.shape == (1, 3, 3, 3)
    torch.testing.assert_close(m.sum(1), torch.ones(1, 3, 3))
    assert (m[0].argmax(0).numpy() == labels).all()


def test_ground_between_spots_becomes_one_label():
    img = discs(32)
    labels = felzenszwalb_labels(img.permute(1, 2, 0).double().numpy(), 400)
    merged, ground = ground_labels(labels, img)
    assert ground
    assert (merged[labels == labels[0, 0]] == 0).all()
    assert all(merged[y, x] > 0 for y, x in ((8, 8), (8, 24), (24, 8), (24, 24)))


def test_textons_follow_the_discs(model):
    img = discs(32)
    labels = segment_labels(img, "felzenszwalb")
    t, _ = initial_textons(model, img, labels)
    centres = sorted(tuple(round(float(c) * 32) for c in mu) for mu in t.mu[0])
    for want in ((8, 8), (8, 24), (24, 8), (24, 24)):  # (x, y) in pixels, +0.5 px centres
        assert min(abs(a - want[0]) + abs(b - want[1]) for a, b in centres) <= 1


def test_kinds_keep_the_background_out_and_split_sizes(textons):
    from dataclasses import replace

    t = textons[0:1]
    K = t.num_textons
    cov = torch.eye(2).repeat(1, K, 1, 1) * 1e-4
    cov[0, :K // 2] *= 100  # half large, half small
    cov[0, 0] = torch.eye(2) * 10.0  # a background layer
    t = replace(t, cov=cov, delta=torch.ones(1, K), f=torch.zeros(1, K, t.feature_dim))
    kinds = texton_kinds(t)
    assert kinds[0, 0] == -1
    assert len(set(kinds[0, 1:K // 2].tolist()) & set(kinds[0, K // 2:].tolist())) == 0 or K < 10


def test_kinds_split_elongated_textons_by_direction_and_aspect():
    from neuraltex.texton_kinds import shape_bins

    def cov(aspect, degrees):
        a = math.radians(degrees)
        R = torch.tensor([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        return R @ torch.diag(torch.tensor([aspect ** 2, 1.0])) @ R.T * 1e-4

    covs = torch.stack([cov(4, 0), cov(4, 178), cov(4, 90), cov(4, 44), cov(1.1, 30),
                        cov(1.1, 120), cov(2.1, 0)]).double()
    elong, direction = shape_bins(covs)
    assert direction[0] == direction[1] != direction[2]  # 0 and 178 degrees: one axis
    assert direction[3] not in (direction[0], direction[2])
    assert direction[4] == direction[5] == -1 and elong[4] == elong[5] == 0  # round-ish
    assert elong[0] == 2 and elong[6] == 1
    t = Textons(mu=torch.rand(1, 7, 2), cov=covs.float()[None], v=torch.ones(1, 7, 2),
                f=torch.zeros(1, 7, 3), p=torch.ones(1, 7), delta=torch.ones(1, 7),
                order=torch.arange(7)[None])
    kinds = texton_kinds(t, max_kinds=1, size_ratio=1e6)
    assert kinds[0, 0] == kinds[0, 1] != kinds[0, 2] and kinds[0, 4] == kinds[0, 5]
    assert len(set(texton_kinds(t, max_kinds=1, size_ratio=1e6, shapes=False)[0].tolist())) == 1


def test_reshuffle_trades_features_only_within_kinds(textons):
    from dataclasses import replace

    t = replace(textons[0:1], delta=torch.ones(1, 5))
    kinds = torch.tensor([[-1, 0, 0, 1, 1]])
    out = reshuffle(t, seed=3, kinds=kinds)
    torch.testing.assert_close(out.f[0, 0], t.f[0, 0])  # the background keeps its own
    assert {tuple(r.tolist()) for r in out.f[0, 1:3]} == {tuple(r.tolist()) for r in t.f[0, 1:3]}
    assert {tuple(r.tolist()) for r in out.f[0, 3:]} == {tuple(r.tolist()) for r in t.f[0, 3:]}


def test_dihedral_moves_image_and_textons_alike(model):
    img = discs(32)
    img[:, :4, :4] = 0.0  # break the symmetry
    t, _ = initial_textons(model, img, segment_labels(img, "felzenszwalb"))
    for code in range(8):
        im2, t2 = dihedral(img, t, code)
        labels2 = segment_labels(im2, "felzenszwalb")
        t3, _ = initial_textons(model, im2, labels2)
        a = sorted(map(tuple, t2.mu[0].round(decimals=3).tolist()))
        b = sorted(map(tuple, t3.mu[0].round(decimals=3).tolist()))
        np.testing.assert_allclose(a, b, atol=2e-3)


@pytest.fixture(scope="module")
def fitted(model):
    return fit_texture(model, discs(32), FitSettings(steps=40, seconds=None,
                                                     segmenter="felzenszwalb", crop=32))


def test_fit_improves_the_reconstruction_and_is_reproducible(model, fitted):
    assert fitted.steps == 40 and fitted.psnr > fitted.base_psnr + 1.0
    again = fit_texture(model, discs(32), FitSettings(steps=40, seconds=None,
                                                      segmenter="felzenszwalb", crop=32))
    assert again.psnr == pytest.approx(fitted.psnr, abs=1e-4)


def test_fit_reports_its_climb_at_every_reading(model, fitted):
    curve = []
    fit = fit_texture(model, discs(32), FitSettings(steps=40, seconds=None, eval_every=10,
                                                    segmenter="felzenszwalb", crop=32),
                      on_eval=lambda *r: curve.append(r))
    assert [c[0] for c in curve] == [0, 10, 20, 30, 40]
    assert curve[0][2] == pytest.approx(fit.base_psnr) and curve[-1][2] == pytest.approx(
        fit.plain_psnr, abs=1e-4)
    assert all(b[1] >= a[1] for a, b in zip(curve, curve[1:], strict=False))  # seconds grow
    assert curve[-1][2] == pytest.approx(fitted.plain_psnr, abs=1e-4)  # no effect on the fit


def test_fit_stops_at_its_time_budget(model):
    fit = fit_texture(model, discs(32), FitSettings(seconds=0.5, segmenter="slic"))
    assert fit.seconds < 5 and fit.steps >= 1


def test_the_budget_covers_the_whole_fit_and_the_tuning_gets_what_is_left():
    from neuraltex.fit import AFTER_TUNING, tuning_budget

    assert tuning_budget(55.0, 2.0) == pytest.approx(55.0 - 2.0 * (1 + AFTER_TUNING))
    assert tuning_budget(5.0, 4.0) == 0.0  # nothing left: one step, then elements and sprites
    assert tuning_budget(None, 4.0) is None


def test_a_fit_with_a_budget_ends_near_it(model):
    import time

    begin = time.perf_counter()
    fit = fit_texture(model, discs(32), FitSettings(seconds=3.0, segmenter="felzenszwalb",
                                                    crop=32))
    total = time.perf_counter() - begin
    assert fit.steps > 1 and total < 3.0 + 2.0  # tuning stopped early enough for the rest


def test_detail_sprites_add_what_the_decoder_misses(model, fitted):
    from neuraltex.texton_detail import auto_side

    assert fitted.detail == auto_side(fitted.textons.num_textons, (32, 32)) >= 8
    plain_width = model.generator.feature_channels + 1  # [f_a, d]
    assert fitted.textons.feature_dim == plain_width + 3 * fitted.detail ** 2
    assert fitted.psnr > fitted.plain_psnr + 3  # dB
    plain = fit_texture(model, discs(32), FitSettings(steps=40, seconds=None, detail=0,
                                                      segmenter="felzenszwalb", crop=32))
    assert plain.textons.feature_dim == model.generator.feature_channels + 1
    assert plain.psnr == pytest.approx(fitted.plain_psnr, abs=1e-4)  # the same tuning before


def test_auto_says_what_it_picked(model):
    fit = fit_texture(model, discs(32), FitSettings(steps=1, seconds=None))
    assert fit.segmenter in ("felzenszwalb", "slic")


def test_texture_file_round_trip(tmp_path, model, fitted):
    path = tmp_path / "t.ntex"
    size = save_texture(path, model, fitted.textons, fitted.labels, fitted.generator,
                        {"size": [32, 32], "source": {}, "segmenter": "x", "fit": {}},
                        fitted.elements)
    assert 0 < size < 2 * 2**20
    tex = load_texture(path, model)
    assert tex.elements is not None and (tex.elements == fitted.elements).all()
    plain = model.generator.feature_channels + 1  # [f_a, d]; detail sprites after
    assert tex.textons.feature_dim == plain + 3 * fitted.detail ** 2
    torch.testing.assert_close(tex.textons.f[..., :plain], fitted.textons.f[..., :plain])
    torch.testing.assert_close(tex.textons.f, fitted.textons.f, atol=2e-3, rtol=0)  # float16
    assert (tex.labels == fitted.labels).all()
    with torch.no_grad():
        a = tuned_model(model, tex.generator).decode(tex.textons, (32, 32))
        b = tuned_model(model, fitted.generator).decode(fitted.textons, (32, 32))
    assert (a - b).abs().max() < 0.02  # float16 deltas


def test_tampered_or_foreign_texture_files_are_refused(tmp_path, model, fitted):
    path = tmp_path / "t.ntex"
    save_texture(path, model, fitted.textons, fitted.labels, fitted.generator,
                 {"size": [32, 32], "source": {}, "segmenter": "x", "fit": {}})
    data = bytearray(path.read_bytes())
    data[-20] ^= 0xFF
    bad = tmp_path / "bad.ntex"
    bad.write_bytes(bytes(data))
    with pytest.raises(TextureFileError, match="checksum"):
        load_texture(bad, model)
    other = build_model(model.config).eval()
    assert model_id(other) != model_id(model)
    with pytest.raises(TextureFileError, match="other base weights"):
        load_texture(path, other)
    (tmp_path / "junk.ntex").write_bytes(b"\x00" * 64)
    with pytest.raises(TextureFileError):
        load_texture(tmp_path / "junk.ntex", model)


def test_texture_files_with_wild_sprites_are_refused(tmp_path, model, fitted):
    from dataclasses import replace

    path = tmp_path / "wild.ntex"
    plain = model.generator.feature_channels + 1
    f = fitted.textons.f.clone()
    f[0, 0, plain] = 50.0  # a sprite texel no fit writes (they lie in [-1, 1])
    save_texture(path, model, replace(fitted.textons, f=f), fitted.labels, fitted.generator,
                 {"size": [32, 32], "source": {}, "segmenter": "x", "fit": {}})
    with pytest.raises(TextureFileError, match="sprites"):
        load_texture(path, model)


def test_fit_groups_the_textons_of_each_disc_into_elements(model, fitted):
    K = fitted.textons.num_textons
    assert fitted.elements.shape == (K,) and 0 < fitted.elements.max() < K  # not all one


def test_texture_files_with_bad_elements_are_refused(tmp_path, model, fitted):
    path = tmp_path / "e.ntex"
    bad = fitted.elements.copy()
    bad[0] = fitted.textons.num_textons  # no such element
    save_texture(path, model, fitted.textons, fitted.labels, fitted.generator,
                 {"size": [32, 32], "source": {}, "segmenter": "x", "fit": {}}, bad)
    with pytest.raises(TextureFileError, match="elements"):
        load_texture(path, model)


def test_plain_textons_get_zero_offsets_in_the_tuned_layout(model, fitted):
    tuned = tuned_model(model, fitted.generator)
    with torch.no_grad():
        enc = model.encode(discs(32)[None])
        lifted = with_offsets(enc.textons)
        assert lifted.feature_dim + 2 == tuned.generator.feature_channels
        out = tuned.decode(lifted, (32, 32))
    assert out.shape == (1, 3, 32, 32) and torch.isfinite(out).all()


def test_more_queries_give_the_learned_segmenter_more_textons_on_a_dense_texture(model):
    """fit --segmenter model --queries: E_s's 100 queries resampled to 196 (no training)
    split the brick wall (about 130 bricks) into more textons than the 100 queries can; only
    the query embeddings differ, and the model itself is left as it was."""
    from pathlib import Path

    from neuraltex.imageio import load_image
    from neuraltex.query_grid import with_queries

    image = load_image(Path(__file__).resolve().parents[1] / "data/real_textures/brick.png")
    assert with_queries(model, 100) is model
    dense, before = with_queries(model, 196), model.state_dict()
    after = dense.state_dict()
    assert after["segmenter.query_feat"].shape[0] == 196
    assert all(torch.equal(after[k], v) for k, v in before.items() if "query_" not in k)
    few = segment_labels(image, "model", model=model)
    many = segment_labels(image, "model", model=model, queries=196)
    assert many.max() + 1 > 1.5 * (few.max() + 1)
    assert model.state_dict()["segmenter.query_feat"].shape[0] == 100
