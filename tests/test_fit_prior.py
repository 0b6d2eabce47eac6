"""The fit prior (neuraltex.fit_prior) and its Reptile trainer (train.fit_prior), on the tiny
untrained export and 32 px procedural textures."""

import json
from dataclasses import replace

import pytest
import torch

from neuraltex.checkpoint import export_model
from neuraltex.fit import FitSettings, fit_texture
from neuraltex.fit_prior import (
    FitPriorError,
    load_prior,
    prior_path,
    save_prior,
    start_generator,
)
from neuraltex.model import load_model
from train import fit_prior as trainer

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.fixture(scope="module")
def model(tiny_checkpoint):
    return load_model(tiny_checkpoint)


def shifted(model, by: float = 0.05) -> dict[str, torch.Tensor]:
    torch.manual_seed(1)
    return {k: v.detach() + by * torch.randn_like(v) for k, v in model.generator.named_parameters()}


def test_prior_lives_beside_its_weights():
    assert prior_path("/a/b/default.safetensors").as_posix() == "/a/b/default.fit_prior.safetensors"


def test_round_trip_and_start(tmp_path, model):
    params = shifted(model)
    save_prior(tmp_path / "p.safetensors", model, params, {"note": "test"})
    loaded, header = load_prior(tmp_path / "p.safetensors", model)
    assert header["info"] == {"note": "test"}
    for k, v in params.items():
        assert torch.equal(loaded[k], v)
    model.fit_prior = (loaded, header)
    try:
        G = start_generator(model)
        assert all(torch.equal(p, params[k]) for k, p in G.named_parameters())
        plain = start_generator(model, use_prior=False)
        assert all(torch.equal(p, q) for p, q in zip(plain.parameters(),
                                                     model.generator.parameters(), strict=True))
    finally:
        model.fit_prior = None


def test_tampered_or_foreign_priors_are_refused(tmp_path, model):
    path = tmp_path / "p.safetensors"
    save_prior(path, model, shifted(model), {})
    data = bytearray(path.read_bytes())
    data[-3] ^= 0xFF  # a weight byte
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(bytes(data))
    with pytest.raises(FitPriorError, match="checksum"):
        load_prior(bad, model)
    other = load_model(trainer.DEFAULT_MODEL)  # the shipped model: another decoder
    with pytest.raises(FitPriorError, match="another decoder|do not match"):
        load_prior(path, other)
    (tmp_path / "junk.safetensors").write_bytes(b"not a file")
    with pytest.raises(FitPriorError, match="not a readable fit prior"):
        load_prior(tmp_path / "junk.safetensors", model)


def test_a_bad_prior_beside_the_weights_is_skipped_with_a_warning(tmp_path, model,
                                                                   tiny_checkpoint):
    weights = tmp_path / "m.safetensors"
    weights.write_bytes(open(tiny_checkpoint, "rb").read())
    prior_path(weights).write_bytes(b"garbage")
    with pytest.warns(UserWarning, match="fit starts from the model's own decoder"):
        loaded = load_model(weights)
    assert loaded.fit_prior is None


def test_fit_starts_from_the_prior_unless_told_not_to(model):
    image = torch.rand(3, 32, 32)
    params = shifted(model, 0.2)
    cfg = FitSettings(steps=1, seconds=None, segmenter="felzenszwalb", crop=32, detail=0)
    starts = {}
    model.fit_prior = (params, {})
    try:
        for use in (True, False):
            curve: list = []
            fit_texture(model, image, replace(cfg, prior=use),
                        on_eval=lambda *r, c=curve: c.append(r))
            starts[use] = curve[0][2]
    finally:
        model.fit_prior = None
    plain = []
    fit_texture(model, image, cfg, on_eval=lambda *r: plain.append(r))
    assert starts[False] == pytest.approx(plain[0][2])
    assert abs(starts[True] - starts[False]) > 1e-3  # the perturbed start decodes otherwise


def run_trainer(tmp_path, weights, *extra):
    return trainer.main(["--weights", str(weights), "--size", "32", "--tasks", "2",
                         "--inner-steps", "2", "--save-every", "1",
                         "--state", str(tmp_path / "state.pt"), *extra])


def test_trainer_writes_a_prior_that_fit_then_uses(tmp_path, tiny_checkpoint, capsys):
    weights = tmp_path / "m.safetensors"
    weights.write_bytes(open(tiny_checkpoint, "rb").read())
    assert run_trainer(tmp_path, weights, "--iterations", "2") == 0
    assert "wrote" in capsys.readouterr().out
    model = load_model(weights)
    params, header = model.fit_prior
    assert header["info"]["iterations_done"] == 2 and header["info"]["inner_steps"] == 2
    moved = max((params[k] - p).abs().max().item() for k, p in model.generator.named_parameters())
    assert moved > 0  # Reptile moved the start toward the tuned decoders


def test_trainer_resumes_exactly_after_an_interrupt(tmp_path, tiny_checkpoint, monkeypatch):
    weights = tmp_path / "m.safetensors"
    weights.write_bytes(open(tiny_checkpoint, "rb").read())
    straight = tmp_path / "straight"
    straight.mkdir()
    assert run_trainer(straight, weights, "--iterations", "3", "--out",
                       str(tmp_path / "a.safetensors")) == 0
    real, calls = trainer.reptile_iteration, []

    def interrupted(*a, **k):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(trainer, "reptile_iteration", interrupted)
    out = str(tmp_path / "b.safetensors")
    assert run_trainer(tmp_path, weights, "--iterations", "3", "--out", out) == 130
    monkeypatch.setattr(trainer, "reptile_iteration", real)
    assert run_trainer(tmp_path, weights, "--iterations", "3", "--out", out) == 0
    model = load_model(weights)
    a, _ = load_prior(tmp_path / "a.safetensors", model)
    b, _ = load_prior(out, model)
    assert all(torch.equal(a[k], b[k]) for k in a)
    # a resume with other settings is refused with one line
    assert run_trainer(tmp_path, weights, "--iterations", "5", "--out", out) == 2


def test_a_run_state_belongs_to_its_weights(tmp_path, tiny_checkpoint, monkeypatch, capsys):
    """The finished state of one model's run must not become another model's prior: by
    default each weights file has its own state; a state named for other weights is refused."""
    a, b = tmp_path / "a.safetensors", tmp_path / "b.safetensors"
    a.write_bytes(open(tiny_checkpoint, "rb").read())
    model = load_model(a)
    with torch.no_grad():
        for p in model.generator.parameters():
            p.add_(0.01)
    export_model(b, model.state_dict(), model.config, model.info)
    monkeypatch.chdir(tmp_path)
    common = ["--size", "32", "--tasks", "2", "--inner-steps", "2", "--iterations", "2"]
    assert trainer.main(["--weights", str(a), *common]) == 0
    assert trainer.main(["--weights", str(b), *common]) == 0
    assert len(list((tmp_path / "runs" / "fit_prior").glob("*.pt"))) == 2
    pa, pb = load_model(a).fit_prior[0], load_model(b).fit_prior[0]
    assert any(not torch.equal(pa[k], pb[k]) for k in pa)  # each learned from its own G
    capsys.readouterr()
    shared = ["--state", str(tmp_path / "shared.pt")]
    assert trainer.main(["--weights", str(a), *common, *shared]) == 0
    assert trainer.main(["--weights", str(b), *common, *shared]) == 2
    assert "a run for other weights or settings" in capsys.readouterr().err


def test_trainer_rejects_bad_arguments(capsys):
    for bad in (["--iterations", "0"], ["--epsilon", "2"], ["--size", "8"]):
        with pytest.raises(SystemExit) as exc:
            trainer.parse(bad)
        assert exc.value.code == 2
    assert json.dumps(trainer.recipe(trainer.parse([])))  # the recipe is JSON for the header
