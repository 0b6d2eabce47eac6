"""How a training launch starts and stops: Ctrl-C, a missing earlier stage, --help."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

import train.loop
from neuraltex.checkpoint import load_training_checkpoint

ROOT = Path(__file__).resolve().parents[1]


def _cfg(run_dir, *overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return compose(config_name="train", overrides=[
            f"run_dir={run_dir}", "debug=fast", "data.augment=false", "trainer.threads=1",
            *overrides])


def test_ctrl_c_finishes_the_step_saves_a_checkpoint_and_stops(tmp_path, monkeypatch):
    step = train.loop.train_step

    def step_then_ctrl_c(parts, images, labels, settings, i, g):
        out = step(parts, images, labels, settings, i, g)
        if i == 1:  # Ctrl-C during the second step
            os.kill(os.getpid(), signal.SIGINT)
        return out

    monkeypatch.setattr(train.loop, "train_step", step_then_ctrl_c)
    before = signal.getsignal(signal.SIGINT)  # SIG_IGN under nohup, else the default
    with pytest.raises(train.loop.Interrupted) as stop:
        train.loop.run(_cfg(tmp_path, "trainer.max_steps=50", "trainer.ckpt_every=100"))
    assert stop.value.step == 2 and stop.value.checkpoint == tmp_path / "last.pt"
    assert load_training_checkpoint(tmp_path / "last.pt")["step"] == 2
    assert not (tmp_path / "model.safetensors").exists()  # no export of a stopped run
    assert signal.getsignal(signal.SIGINT) is before  # the run's handler is removed


def _train(cwd: Path, *overrides: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "train", *overrides], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_missing_earlier_stage_is_one_line_and_leaves_no_run_folder(tmp_path):
    out = _train(tmp_path, "experiment=default_finetune")
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        "train: error: trainer.init_from: runs/default/model.safetensors does not exist; "
        "train that stage first: python -m train experiment=default"]
    assert not list(tmp_path.iterdir())  # no runs/<name>/ of the failed launch


def test_help_is_short_and_lists_the_groups(tmp_path):
    out = _train(tmp_path, "--help")
    assert out.returncode == 0 and len(out.stdout.splitlines()) < 30
    assert "experiment: default, default_finetune, default_segmenter" in out.stdout


def test_training_logs_pictures_without_tensorboard(tmp_path, monkeypatch, capsys):
    import sys

    from train.logging import Logger

    monkeypatch.setitem(sys.modules, "torch.utils.tensorboard", None)  # import fails
    logger = Logger(tmp_path, enabled=True)
    assert logger.writer is None and "tensorboard is not installed" in capsys.readouterr().err
    logger.scalars(1, {"recon": 0.5})  # a no-op, not an error
    logger.close()


def test_a_run_that_resumes_needs_none_of_the_files_it_started_from(tmp_path):
    from omegaconf import OmegaConf

    from neuraltex.errors import InputError
    from train.setup import check_inputs

    T = OmegaConf.create({"init_from": "runs/default/model.safetensors",
                          "init_parts": {"segmenter": "runs/long_segmenter/model.safetensors"},
                          "resume": "auto"})
    with pytest.raises(InputError, match="trainer.init_from: runs/default/model.safetensors"):
        check_inputs(T, tmp_path)
    (tmp_path / "last.pt").write_bytes(b"")  # resumed from here: the start files are history
    check_inputs(T, tmp_path)
    T.resume = None  # not resuming: they are needed again
    with pytest.raises(InputError):
        check_inputs(T, tmp_path)
