"""The training program end to end on a miniature model (CPU, seconds per step)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir

from neuraltex.checkpoint import load_training_checkpoint
from neuraltex.model import load_model
from neuraltex.model_config import ModelConfig
from train.loop import run

ROOT = Path(__file__).resolve().parents[1]
FAST = ["debug=fast", "data.augment=false", "trainer.threads=1"]


def _cfg(run_dir, *overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return compose(config_name="train", overrides=[f"run_dir={run_dir}", *FAST, *overrides])


def test_run_writes_checkpoint_export_and_pictures(tmp_path):
    logs = run(_cfg(tmp_path, "trainer.max_steps=2"))
    assert all(torch.isfinite(torch.tensor(v)) for v in logs.values())
    assert load_training_checkpoint(tmp_path / "last.pt")["step"] == 2
    assert sorted(p.name for p in (tmp_path / "images").glob("*.png")) == ["step_0000002.png"]
    model = load_model(tmp_path / "model.safetensors")
    assert model.info["steps"] == 2 and model.info["lpips_backbone"] == "random"
    assert list((tmp_path / "tb").glob("events.*"))


@pytest.mark.slow
def test_resume_continues_exactly(tmp_path):
    full = run(_cfg(tmp_path / "a", "trainer.max_steps=3", "trainer.ckpt_every=2",
                    "trainer.export=null"))
    # Interrupted run: stop after 2 steps, then resume to 3.
    run(_cfg(tmp_path / "b", "trainer.max_steps=2", "trainer.export=null"))
    resumed = run(_cfg(tmp_path / "b", "trainer.max_steps=3", "trainer.resume=auto",
                       "trainer.export=null"))
    assert resumed["total"] == pytest.approx(full["total"], rel=1e-5, abs=1e-6)
    assert resumed["recon"] == pytest.approx(full["recon"], rel=1e-5, abs=1e-6)


def test_gt_mask_supervision_path(tmp_path):
    logs = run(_cfg(tmp_path, "trainer.max_steps=1", "loss.mask_supervision=gt",
                    "trainer.export=null"))
    assert "mask" in logs and logs["mask"] > 0


def test_a_distributed_run_destroys_its_process_groups(tmp_path, monkeypatch):
    """Under torchrun the trainer leaves no gloo group alive: a process exiting with one can
    abort in its destructor ("terminate called without an active exception", SIGABRT) after
    a finished run (CI, session 26). Here a one-rank world, set up as torchrun does."""
    import socket

    import torch.distributed as dist

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for key, value in {"RANK": "0", "LOCAL_RANK": "0", "WORLD_SIZE": "1",
                       "MASTER_ADDR": "127.0.0.1", "MASTER_PORT": str(port)}.items():
        monkeypatch.setenv(key, value)
    logs = run(_cfg(tmp_path, "trainer.max_steps=1", "trainer.export=null"))
    assert "recon" in logs
    assert not dist.is_initialized()


@pytest.mark.slow
@pytest.mark.parametrize("sync", [False, True], ids=["rank-batchnorm", "sync-batchnorm"])
def test_ddp_two_processes_on_cpu(tmp_path, sync):
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "torch.distributed.run", "--nproc_per_node=2",
           f"--master_port={29517 + sync}", "-m", "train", *FAST, "trainer.max_steps=2",
           "trainer.batch_size=2", f"run_dir={tmp_path}", f"trainer.sync_batchnorm={sync}",
           # the CPU presets' lazy terms: D_p has no loss on every other step (DDP must
           # allow unused parameters there)
           "loss.equivariance_every=2", "loss.reshuffle_every=2",
           # the export recalibrates BatchNorm on rank 0 alone (no collective may wait there)
           "trainer.bn_recalibration=4"]
    out = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert load_training_checkpoint(tmp_path / "last.pt")["step"] == 2
    assert (tmp_path / "model.safetensors").is_file()


@pytest.mark.slow
def test_overfit_one_batch_lowers_reconstruction_loss():
    from neuraltex.data.generator import generate
    from neuraltex.model import build_model
    from train.loss_config import LossConfig, StepSettings
    from train.objective import CriticObjective, GeneratorObjective

    torch.manual_seed(0)
    torch.set_num_threads(1)
    images = torch.stack([torch.from_numpy(generate(i, 0, 32).image).permute(2, 0, 1)
                          for i in range(4)]).float()
    model, d, dp = build_model(ModelConfig(), with_critics=True)
    loss = LossConfig(equivariance=False, reshuffle=False, gan=False, w_lpips=0.0)
    objective = GeneratorObjective(model, CriticObjective(d, dp, loss), loss)
    opt = torch.optim.Adam(model.parameters(), lr=2e-3, betas=(0.5, 0.999))
    w = StepSettings(entropy=0.0, compact=0.0, csis=0.0, texture=0.0, gan=0.0, pgan=0.0,
                     mask=0.0, patch_size=2, existence="all")
    losses = []
    for step in range(80):
        out = objective(images, None, w, torch.Generator().manual_seed(step))
        opt.zero_grad()
        out.loss.backward()
        opt.step()
        losses.append(out.logs["recon"])
    first, last = sum(losses[:5]) / 5, sum(losses[-5:]) / 5
    assert last < 0.6 * first, (first, last)
    assert out.logs["diag/l1"] < out.logs["diag/l1_constant"]  # beats a constant image


def test_segmenter_warmup_trains_only_the_segmenter(tmp_path):
    """During loss.segmenter_warmup only E_s changes; E_FC, G and the critics stay put."""
    cfg = _cfg(tmp_path, "trainer.max_steps=2", "loss.mask_supervision=gt",
               "loss.segmenter_warmup=100", "trainer.schedule_scale=1")
    torch.manual_seed(cfg.seed)
    from neuraltex.model import build_model

    before, _, _ = build_model(ModelConfig(), with_critics=True)
    logs = run(cfg)
    assert "mask" in logs and "recon" not in logs and "d" not in logs
    after = load_training_checkpoint(tmp_path / "last.pt")["modules"]["model"]
    changed = {name: not torch.equal(value, after[name])
               for name, value in before.state_dict().items()}
    assert not any(c for name, c in changed.items() if not name.startswith("segmenter."))
    seg = [c for name, c in changed.items() if name.startswith("segmenter.")]
    # (at 32 px the stride-32 memory is one token, so a few attention weights get no gradient)
    assert sum(seg) > 0.8 * len(seg)


def test_max_minutes_stops_early_and_exports_the_steps_done(tmp_path):
    run(_cfg(tmp_path, "trainer.max_steps=50", "trainer.max_minutes=1e-6"))
    assert load_training_checkpoint(tmp_path / "last.pt")["step"] == 1
    assert load_model(tmp_path / "model.safetensors").info["steps"] == 1


def test_init_from_and_num_queries(tmp_path):
    run(_cfg(tmp_path / "a", "trainer.max_steps=1", "model.num_queries=5"))
    src = load_model(tmp_path / "a" / "model.safetensors")
    assert src.segmenter.num_queries == 5 and src.config.num_queries == 5
    run(_cfg(tmp_path / "b", "trainer.max_steps=1", "model.num_queries=5", "loss.gan=false",
             "trainer.lr=0", f"trainer.init_from={tmp_path / 'a' / 'model.safetensors'}"))
    dst = load_model(tmp_path / "b" / "model.safetensors")
    dst_params = dict(dst.named_parameters())
    for name, a in src.named_parameters():  # (buffers such as spectral-norm vectors do move)
        assert torch.equal(a, dst_params[name]), name  # lr = 0: the weights started from


def test_crops_keep_labels_aligned_and_freeze_keeps_the_segmenter(tmp_path):
    from train.data import crop_batch

    labels = torch.arange(2 * 12 * 12).reshape(2, 12, 12)
    images = labels[:, None].float().expand(2, 3, 12, 12) / 1000
    ci, cl = crop_batch(images, labels, 5, torch.Generator().manual_seed(0))
    assert ci.shape == (2, 3, 5, 5) and cl.shape == (2, 5, 5) and cl.dtype == labels.dtype
    assert torch.equal((ci[:, 0] * 1000).round().long(), cl)  # same window in both
    assert crop_batch(images, None, None, torch.Generator())[0] is images

    cfg = _cfg(tmp_path, "trainer.max_steps=1", "model.image_size=48", "data.crop=32",
               "trainer.freeze=[segmenter]",
               "loss.mask_supervision=gt")
    torch.manual_seed(cfg.seed)
    from neuraltex.model import build_model

    before = build_model(ModelConfig()).state_dict()
    run(cfg)
    after = load_training_checkpoint(tmp_path / "last.pt")["modules"]["model"]
    for name, value in before.items():
        if name.startswith("segmenter."):
            assert torch.equal(value, after[name]), name
    assert not torch.equal(before["generator.fc.weight"], after["generator.fc.weight"])


def test_lr_factor_milestones_scale_both_optimizers(tmp_path):
    from neuraltex.model import build_model
    from train.setup import model_config

    cfg = _cfg(tmp_path / "a", "trainer.max_steps=1", "trainer.lr_factor=[[0,0.0],[5,1.0]]")
    torch.manual_seed(cfg.seed)
    before = dict(build_model(model_config(cfg), with_critics=True)[0].named_parameters())
    run(cfg)
    after = load_training_checkpoint(tmp_path / "a" / "last.pt")
    assert all(torch.equal(before[k], after["modules"]["model"][k]) for k in before)  # lr 0
    assert all(g["lr"] == 0 for o in after["optimizers"].values() for g in o["param_groups"])
    run(_cfg(tmp_path / "b", "trainer.max_steps=1", "trainer.lr_factor=0.5", "trainer.lr=1e-3"))
    groups = load_training_checkpoint(tmp_path / "b" / "last.pt")["optimizers"]["g"]
    assert groups["param_groups"][0]["lr"] == pytest.approx(5e-4)


@pytest.mark.slow
def test_init_parts_take_one_part_from_another_model(tmp_path):
    from neuraltex.checkpoint import summary

    run(_cfg(tmp_path / "a", "trainer.max_steps=1", "model.num_queries=5", "seed=1"))
    run(_cfg(tmp_path / "s", "trainer.max_steps=2", "model.num_queries=5", "seed=2"))
    a, s = (load_model(tmp_path / n / "model.safetensors") for n in "as")
    run(_cfg(tmp_path / "b", "trainer.max_steps=1", "model.num_queries=5", "trainer.lr=0",
             "loss.gan=false", f"trainer.init_from={tmp_path / 'a' / 'last.pt'}",
             f"+trainer.init_parts.segmenter={tmp_path / 's' / 'model.safetensors'}"))
    b = load_model(tmp_path / "b" / "model.safetensors")
    src = dict(a.named_parameters()) | {f"segmenter.{k}": v
                                        for k, v in s.segmenter.named_parameters()}
    for name, value in b.named_parameters():
        assert torch.equal(value, src[name]), name
    assert b.info["init_from"]["path"].endswith("last.pt")
    assert b.info["init_parts"]["segmenter"]["info"]["steps"] == 2
    assert "segmenter taken from a 2-step model" in summary(b.config.to_dict(), b.info)
    with pytest.raises(ValueError, match="no model part"):
        run(_cfg(tmp_path / "c", "trainer.max_steps=1", "model.num_queries=5",
                 f"+trainer.init_parts.nosuchpart={tmp_path / 's' / 'model.safetensors'}"))


def test_batchnorm_recalibration_changes_only_the_export(tmp_path):
    from safetensors.torch import load_file

    cfg = _cfg(tmp_path, "trainer.max_steps=1", "model.image_size=48", "data.crop=32",
               "trainer.bn_recalibration=8", "loss.gan=false")
    run(cfg)
    trained = load_training_checkpoint(tmp_path / "last.pt")["modules"]["model"]
    exported = load_file(tmp_path / "model.safetensors")
    stats = [k for k in trained if k.endswith("running_mean")]
    assert {k.split(".")[0] for k in stats} == {"encoder", "generator"}  # E_FC and G
    assert all(not torch.equal(trained[k], exported[k]) for k in stats)
    # one cumulative pass over 8 images: the counters say so
    assert all(int(exported[k.replace("running_mean", "num_batches_tracked")])
               == 8 // cfg.trainer.batch_size for k in stats)
    others = [k for k in trained if "running_" not in k and "num_batches" not in k]
    assert all(torch.equal(trained[k], exported[k]) for k in others)
    assert load_model(tmp_path / "model.safetensors").info["bn_recalibration"] == 8


def test_long_segmenter_preset_runs_and_resumes(tmp_path):
    """The long-run preset (MODEL.md, issue 16 item 5) at 2 steps: point-sampled mask loss,
    data worker, stop and resume from run_dir/last.pt. It compiles E_s (inductor: a minute
    or more here), which test_compiled_segmenter_trains_as_the_eager_one covers: not here."""
    assert list(_cfg(tmp_path, "experiment=long_segmenter").trainer.compile) == ["segmenter"]
    over = ["experiment=long_segmenter", "model.image_size=64", "model.estimation_size=32",
            "trainer.batch_size=2", "trainer.export=null", "loss.mask_points=256",
            "trainer.compile=[]"]
    run(_cfg(tmp_path, *over, "trainer.max_steps=1"))
    logs = run(_cfg(tmp_path, *over, "trainer.max_steps=2"))
    assert load_training_checkpoint(tmp_path / "last.pt")["step"] == 2 and logs["mask"] > 0


@pytest.mark.slow
def test_compiled_segmenter_trains_as_the_eager_one(tmp_path, monkeypatch):
    """trainer.compile=[segmenter]: E_s is compiled in place (the export has the eager
    model's keys) and its steps give the eager steps' losses. Traced by dynamo and AOT
    autograd as with inductor, run by their eager backend (inductor's C++ build takes a
    minute or more here; scripts/bench_model.py times it)."""
    from train.setup import build

    compile_ = torch.nn.Module.compile
    monkeypatch.setattr(torch.nn.Module, "compile",
                        lambda self, **kw: compile_(self, backend="aot_eager", **kw))
    over = ["trainer.max_steps=2", "loss.mask_supervision=gt", "loss.segmenter_warmup=100"]
    parts = build(_cfg(tmp_path / "c", *over, "trainer.compile=[segmenter]"),
                  torch.device("cpu"))
    assert parts.model.segmenter._compiled_call_impl is not None
    assert parts.model.encoder._compiled_call_impl is None
    eager = run(_cfg(tmp_path / "e", *over))
    compiled = run(_cfg(tmp_path / "c", *over, "trainer.compile=[segmenter]"))
    assert compiled["mask"] == pytest.approx(eager["mask"], rel=1e-5)
    assert (load_model(tmp_path / "c" / "model.safetensors").state_dict().keys()
            == load_model(tmp_path / "e" / "model.safetensors").state_dict().keys())


def test_compile_without_a_cxx_compiler_runs_uncompiled_with_one_warning(tmp_path,
                                                                        monkeypatch):
    import train.setup as setup

    monkeypatch.setattr(setup.shutil, "which", lambda name: None)
    monkeypatch.delenv("CXX", raising=False)
    with pytest.warns(UserWarning, match="no C.. compiler") as caught:
        parts = setup.build(_cfg(tmp_path, "trainer.compile=[segmenter]"), torch.device("cpu"))
    assert parts.model.segmenter._compiled_call_impl is None
    assert sum("compiler" in str(w.message) for w in caught) == 1


@pytest.mark.parametrize("key", ["compile", "freeze"])
def test_an_unknown_model_part_is_a_one_line_error(tmp_path, key):
    from neuraltex.errors import InputError
    from train.setup import build, check_inputs

    cfg = _cfg(tmp_path, f"trainer.{key}=[critic]")
    for check in (lambda: check_inputs(cfg.trainer, tmp_path),  # before anything is built
                  lambda: build(cfg, torch.device("cpu"))):
        with pytest.raises(InputError, match=f"trainer.{key}: unknown model part 'critic'"):
            check()


def test_fine_mask_stride_trains_and_exports(tmp_path):
    run(_cfg(tmp_path, "trainer.max_steps=1", "model.mask_stride=2",
             "loss.mask_supervision=gt"))
    model = load_model(tmp_path / "model.safetensors")
    assert model.config.mask_stride == 2 and model.segmenter.upsampler is not None


def test_bfloat16_autocast_on_cpu(tmp_path):
    """trainer.amp on CPU: the estimation runs in float32 (no bfloat16 LU), the step is finite."""
    logs = run(_cfg(tmp_path, "trainer.max_steps=1", "trainer.amp=true", "trainer.export=null"))
    assert all(torch.isfinite(torch.tensor(v)) for v in logs.values())


def test_building_on_cpu_flushes_subnormal_floats(tmp_path):
    """Subnormal floats (softmax masks reach 1e-40) cost ~100x a normal one on x86: the trainer
    and the CLI flush them to zero (docs/training_speed.md)."""
    from train.setup import build

    if not torch.set_flush_denormal(False):
        pytest.skip("this CPU cannot flush subnormal floats")
    tiny = torch.tensor([1e-39], dtype=torch.float64)
    assert float(tiny.float() * 1.0) != 0.0
    build(_cfg(tmp_path), torch.device("cpu"))
    assert float(tiny.float() * 1.0) == 0.0
    torch.set_flush_denormal(False)  # and every command that loads the model
    from neuraltex.cli import common

    common.load(None)
    assert float(tiny.float() * 1.0) == 0.0


def test_a_run_from_the_data_cache_trains_on_the_same_items(tmp_path):
    """data.cache=DIR: the items come from the folder (python -m neuraltex.data.cache), the
    same as rendered up to 8 bits, so the run's losses match a rendering run's closely."""
    from omegaconf import OmegaConf

    from neuraltex.data.cache import write_cache
    from train.data import build_dataset

    cfg = _cfg(tmp_path / "a", "trainer.max_steps=2", "trainer.export=null")
    write_cache(build_dataset(cfg.data, 1), tmp_path / "cache",
                2 * cfg.trainer.batch_size, workers=0, progress=False)
    rendered = run(cfg)
    cached = run(_cfg(tmp_path / "b", "trainer.max_steps=2", "trainer.export=null",
                      f"data.cache={tmp_path / 'cache'}"))
    assert OmegaConf.select(cfg, "data.cache") is None
    assert cached["recon"] == pytest.approx(rendered["recon"], rel=0.02)
    assert cached["recon"] != rendered["recon"]  # 8-bit images: not bit-identical


@pytest.mark.skipif(torch.cuda.is_available(), reason="needs a machine without CUDA")
def test_cuda_without_a_gpu_is_a_one_line_error(tmp_path):
    """trainer.device=cuda where there is no GPU: the CLI's one-line error (exit 2), and the
    launch leaves no run folder behind."""
    run_dir = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "train", f"run_dir={run_dir}", *FAST,
                           "trainer.device=cuda"], capture_output=True, text=True, cwd=ROOT,
                          timeout=300)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines()[-1].startswith("train: error: trainer.device=cuda")
    assert "Traceback" not in proc.stderr and not run_dir.exists()
