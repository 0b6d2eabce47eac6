"""scripts/train_paper_gpu.py (issue 16, item 6): its run's config, and the whole command as a
dry run on the CPU with a tiny model (the GPU itself is never needed by the tests)."""

import json
import sys
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import train_paper_gpu  # noqa: E402

from neuraltex.model import load_model  # noqa: E402
from train.setup import loss_config  # noqa: E402


def _cfg(argv, steps=6000, minutes=8.0):
    args = train_paper_gpu.build_parser().parse_args(argv)
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return compose(config_name="train",
                       overrides=train_paper_gpu.overrides(args, steps, minutes))


def test_the_run_is_the_paper_preset_on_a_gpu_with_its_milestones_scaled():
    cfg = _cfg(["--workers", "6"])
    assert cfg.model.preset == "paper" and cfg.model.image_size == 128
    assert cfg.trainer.device == "cuda" and cfg.trainer.amp is True
    assert cfg.trainer.batch_size == 64 and cfg.trainer.max_steps == 6000
    assert cfg.trainer.max_minutes == 8.0
    assert cfg.trainer.schedule_scale == pytest.approx(0.06)
    assert cfg.loss.mask_supervision == "none" and cfg.loss.segmenter_warmup == 0
    assert cfg.loss.equivariance_every == 1 and cfg.loss.reshuffle_every == 1  # the paper's
    assert cfg.data.num_workers == 6 and cfg.trainer.resume is None
    warm = _cfg(["--recipe", "warm-start", "--warm-start-steps", "600", "--steps", "3000"], 3000)
    assert warm.loss.mask_supervision == "gt"
    # segmenter_warmup counts paper steps: exactly the first N run steps are the warm-up
    for steps, first in ((3000, 600), (3, 1), (7, 3), (6000, 1000), (100_000, 999)):
        cfg = _cfg(["--recipe", "warm-start", "--warm-start-steps", str(first), "--steps",
                    str(steps)], steps)
        losses, scale = loss_config(cfg), cfg.trainer.schedule_scale
        assert [losses.at(s, scale).segmenter_only for s in (0, first - 1, first)] == [
            True, True, False]
    assert _cfg(["--device", "cpu", "--set", "trainer.batch_size=4"]).trainer.batch_size == 4
    # --steps auto: what the training budget holds at the probed step time, 10 % kept back
    assert train_paper_gpu.budget_steps(480, 0.4) == 1080
    assert train_paper_gpu.budget_steps(1, 30.0) == 1


def test_the_probe_times_a_step_of_the_run():
    cfg = _cfg(["--device", "cpu", "--workers", "0", "--set", "model=tiny", "model.image_size=32",
                "trainer.batch_size=2", "trainer.threads=1"], steps=1)
    step_s = train_paper_gpu.probe(cfg, warmup=1, timed=1)
    assert 0 < step_s < 30


@pytest.mark.slow
def test_dry_run_on_the_cpu_trains_benchmarks_and_reports(tmp_path, capsys):
    run_dir = tmp_path / "run"
    code = train_paper_gpu.main([
        "--device", "cpu", "--minutes", "0.3", "--eval-minutes", "0.2", "--limit", "2",
        "--recon-limit", "1", "--workers", "0", "--run-dir", str(run_dir),
        "--set", "model=tiny", "model.image_size=32", "trainer.batch_size=2",
        "trainer.threads=1", "data.augment=false"])
    assert code == 0
    out, err = capsys.readouterr()
    planned = int(err.split(" steps planned")[0].split()[-1])  # --steps auto: the probe's plan
    steps = load_model(run_dir / "model.safetensors").info["steps"]
    assert 1 <= steps <= planned
    results = json.loads((run_dir / "benchmark.json").read_text())["results"]
    assert sorted(results) == ["felzenszwalb", "kmeans", "model"]
    assert all(len(rows) == 2 for rows in results.values())
    report = (run_dir / "report.md").read_text()
    assert "steps/s" in report and "| kmeans |" in report and "PSNR" in report
    assert f"{planned} steps planned" in report
    assert report in out


def test_bad_inputs_are_one_line_errors(tmp_path, capsys):
    used = tmp_path / "used"
    used.mkdir()
    (used / "last.pt").write_bytes(b"")
    cases = [["--device", "cpu", "--run-dir", str(used)],
             ["--device", "cpu", "--eval-minutes", "10"],
             ["--device", "cpu", "--steps", "0"],
             ["--device", "cpu", "--recipe", "warm-start", "--warm-start-steps", "6000",
              "--steps", "6000"],
             ["--device", "tpu"], ["--steps", "many"]]
    if not torch.cuda.is_available():
        cases.append(["--run-dir", str(tmp_path / "new")])
    for argv in cases:
        assert train_paper_gpu.main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("train_paper_gpu: error:") and err.count("\n") == 1, err
    assert not (tmp_path / "new").exists()
