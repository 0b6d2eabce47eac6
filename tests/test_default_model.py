"""The shipped default model: loads offline, encodes plausibly, refuses tampered weights."""

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from neuraltex.checkpoint import CheckpointError
from neuraltex.cli import main
from neuraltex.data.splits import benchmark_split
from neuraltex.model import DEFAULT_MODEL, load_model

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def model():
    torch.set_num_threads(1)
    return load_model(DEFAULT_MODEL)


def test_shipped_weights_are_small_and_describe_their_training(model):
    assert DEFAULT_MODEL.stat().st_size <= 30 * 2**20
    assert model.info["steps"] > 0 and "init_from" in model.info  # trained in stages, MODEL.md
    assert model.segmenter.num_queries == 100


def test_version_and_model_info_name_the_default_model(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    out = capsys.readouterr().out
    assert "neuraltex" in out and "default model: preset tiny, 100 queries" in out
    assert main(["model-info"]) == 0
    out = capsys.readouterr().out
    assert "(shipped default)" in out
    assert "fit prior: default.fit_prior.safetensors (Reptile, 400 iterations" in out


def test_the_shipped_fit_prior_belongs_to_the_shipped_decoder(model):
    from neuraltex.fit_prior import start_generator

    params, header = model.fit_prior  # loaded and checked with the model
    assert header["info"]["iterations_done"] == 400
    G = start_generator(model)
    assert any(not torch.equal(p, q) for p, q in zip(G.parameters(),
                                                     model.generator.parameters(), strict=True))


def test_encoding_an_easy_benchmark_image_gives_a_plausible_texton_count(model):
    items = [it for it in benchmark_split() if it.family == "discs" and it.size == 128][:3]
    for it in items:
        s = it.load()
        truth = len(np.unique(s.mask)) - 1
        x = torch.from_numpy(s.image).permute(2, 0, 1).float()[None]
        with torch.no_grad():
            n = int((model.encode(x).textons.p > 0.5).sum())
        assert 0.5 * truth <= n <= 2 * truth, (it.index, n, truth)


@pytest.mark.parametrize("rgb", [(0.05, 0.05, 0.05), (0.4, 0.08, 0.05), (0.8, 0.5, 0.3),
                                 (0.9, 0.9, 0.95)], ids=["near-black", "dark-red", "tan", "white"])
def test_a_flat_picture_has_no_blob_at_its_centre(model, rgb):
    """The background texton's Gaussian sits at the picture's centre, where G renders its
    appearance code alone. A decoder that gets that code's colour wrong paints a blob there
    (the long stage 2, MODEL.md: 0.245 mean error in the centre of the near-black picture
    against 0.047 around it); the shipped one must not."""
    g = torch.Generator().manual_seed(0)
    x = (torch.tensor(rgb)[:, None, None] + 0.03 * torch.randn(3, 128, 128, generator=g))
    x = x.clamp(0, 1)[None]
    with torch.no_grad():
        error = (model.reconstruct(x)[0] - x[0]).abs().mean(0)
    yy, xx = torch.meshgrid(torch.arange(128.0), torch.arange(128.0), indexing="ij")
    r2 = (yy - 63.5) ** 2 + (xx - 63.5) ** 2
    centre, ring = error[r2 < 20**2].mean(), error[(r2 >= 28**2) & (r2 < 48**2)].mean()
    assert centre < 1.5 * ring + 0.01, (float(centre), float(ring))


def test_tampered_weights_are_rejected(tmp_path, capsys):
    bad = tmp_path / "tampered.safetensors"
    shutil.copy(DEFAULT_MODEL, bad)
    data = bytearray(bad.read_bytes())
    data[-100] ^= 0xFF  # a byte of the last tensor
    bad.write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match="checksum"):
        load_model(bad)
    assert main(["model-info", "--checkpoint", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "checksum" in err


@pytest.mark.slow
def test_eval_model_script_and_its_mask_colour_reference(tmp_path):
    import json

    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import eval_model
    finally:
        sys.path.pop(0)
    # Hard masks over flat regions: the mask-colour image is the input itself.
    x = torch.zeros(1, 3, 8, 8)
    x[..., :, 4:] = torch.tensor([0.2, 0.5, 0.9])[:, None, None]
    masks = torch.stack([(x[0, 0] == 0).float(), (x[0, 0] > 0).float()])[None]
    assert torch.allclose(eval_model.mask_colours(masks, x), x, atol=1e-6)
    out = tmp_path / "e.json"
    assert eval_model.main(["--limit", "2", "--quiet", "--threads", "1", "--json", str(out)]) == 0
    mean = json.loads(out.read_text())["mean"]
    assert mean["psnr_mask_colours"] > mean["psnr_constant"]  # the masks carry the layout
    assert all(np.isfinite(mean[k]) for k in ("psnr", "cc_R", "swd_recon", "swd_reshuffled",
                                              "swd_reshuffled_kinds"))
    # the background layer (kind -1) keeps its features: nothing of one kind -1 moves
    model = load_model(DEFAULT_MODEL)
    with torch.no_grad():
        image = torch.rand(1, 3, 64, 64, generator=torch.Generator().manual_seed(0))
        textons = model.encode(image).textons
        still = torch.full(textons.p.shape, -1, dtype=torch.int64)
        assert torch.equal(eval_model._reshuffled(model, textons, 3, still),
                           model.decode(textons, (eval_model.SIZE,) * 2))
        assert not torch.equal(eval_model._reshuffled(model, textons, 3),
                               model.decode(textons, (eval_model.SIZE,) * 2))
