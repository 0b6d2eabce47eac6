"""The paper preset trained end to end on one GPU within a time budget, then benchmarked
(issue 16, item 6): one command, one report.

    python scripts/train_paper_gpu.py                        # on a machine with a CUDA GPU
    python scripts/train_paper_gpu.py --recipe warm-start    # E_s first learns the GT textons
    python scripts/train_paper_gpu.py --minutes 30 --steps 15000

``model=paper`` (ResNet-50 E_s, 100 queries, 384 feature channels, 128 px), ``trainer=gpu``
(batch 64, bfloat16 autocast) and the paper's eq. 4.24 (``loss=default``: unsupervised, every
term on every step) with its milestones scaled to ``--steps``. Training stops at ``--steps``
or when the training share of ``--minutes`` is spent (checkpoint + export), then the export is
scored on the held-out benchmark split beside k-means and Felzenszwalb
(``scripts/eval_textons.py``) and for reconstruction (``scripts/eval_model.py``); the report
(steps/s, images/s, the benchmark, the total wall time against the budget) is printed and
written to RUN_DIR/report.md.

Never part of the tests' or CI's requirements: a test runs this command on the CPU with a
tiny model and a few steps (``--device cpu --set model=tiny ...``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "scripts")]

from neuraltex.errors import InputError, OneLineParser, cli_entry  # noqa: E402
from neuraltex.fileio import write_text_atomic  # noqa: E402

PAPER_STEPS = 100_000  # the last milestone of loss/default (w_entropy) in paper steps
BASELINES = ("kmeans", "felzenszwalb")


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="train_paper_gpu", description=__doc__.split("\n")[0],
                      formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--minutes", type=float, default=10.0,
                   help="wall-clock budget of the whole command, benchmark included")
    p.add_argument("--eval-minutes", type=float, default=2.0,
                   help="the part of --minutes kept for the benchmark after training")
    p.add_argument("--steps", type=_steps, default="auto",
                   help="training steps, the loss milestones scaled to them; auto: as many as "
                   "the training budget holds at the step time a short probe measures")
    p.add_argument("--recipe", choices=("paper", "warm-start"), default="paper",
                   help="paper: eq. 4.24 unsupervised from scratch; warm-start: E_s alone "
                   "learns the procedural ground-truth textons for --warm-start-steps first, "
                   "then eq. 4.24 with that mask term")
    p.add_argument("--warm-start-steps", type=int, default=1000,
                   help="with --recipe warm-start: steps of E_s alone")
    p.add_argument("--run-dir", default="runs/paper_gpu",
                   help="new (or empty) folder for the checkpoint, export, pictures, report")
    p.add_argument("--device", choices=("cuda", "cpu"), default="cuda",
                   help="cpu: a dry run of the same command (tests)")
    p.add_argument("--workers", type=int, default=None,
                   help="data processes rendering the procedural batches (None: the CPU "
                   "cores less 2, at most 12)")
    p.add_argument("--limit", type=int, default=100,
                   help="benchmark images scored for texton extraction")
    p.add_argument("--recon-limit", type=int, default=20,
                   help="benchmark images scored for reconstruction and edits")
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="extra Hydra overrides of the training run, applied last")
    return p


def _steps(text: str) -> int | str:
    if text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of steps or 'auto': {text!r}") from None


def overrides(args: argparse.Namespace, steps: int, minutes: float) -> list[str]:
    """The Hydra overrides of a training run of ``steps`` steps that stops after ``minutes``
    (with a checkpoint and the export) if it has not finished by then."""
    scale = steps / PAPER_STEPS
    workers = args.workers
    if workers is None:  # the CPU cores less the main process's and one to spare
        workers = max(0, min(12, (os.cpu_count() or 2) - 2))
    over = ["model=paper", "trainer=gpu", "loss=default", f"run_dir={args.run_dir}",
            f"trainer.max_steps={steps}", f"trainer.max_minutes={minutes:.3f}",
            f"trainer.schedule_scale={scale}", f"data.num_workers={workers}",
            "trainer.resume=null", f"trainer.log_every={max(1, min(100, steps // 50))}",
            f"trainer.image_every={max(1, steps // 4)}", f"trainer.ckpt_every={max(1, steps // 4)}"]
    if args.device == "cpu":
        over += ["trainer.device=cpu", "trainer.amp=false"]
    if args.recipe == "warm-start":
        over += ["loss.mask_supervision=gt",
                 f"loss.segmenter_warmup={_paper_steps(args.warm_start_steps, scale)}"]
    return over + list(args.set)


def _paper_steps(first: int, scale: float) -> int:
    """loss.segmenter_warmup (paper steps) that makes exactly the run's first ``first`` steps
    warm-up steps: the trainer's test is run step s < warm-up x scale."""
    paper = math.floor(first / scale)
    while paper * scale > first:
        paper -= 1
    while paper * scale <= first - 1:
        paper += 1
    return paper


def check(args: argparse.Namespace) -> None:
    """One-line errors for the arguments (a missing GPU is the trainer's own error)."""
    if not 0 < args.eval_minutes < args.minutes:
        raise InputError("--eval-minutes must be > 0 and below --minutes")
    for name in ("steps", "limit", "recon_limit"):
        if getattr(args, name) != "auto" and getattr(args, name) < 1:
            raise InputError(f"--{name.replace('_', '-')} must be >= 1")
    if args.recipe == "warm-start" and not 1 <= args.warm_start_steps < (
            math.inf if args.steps == "auto" else args.steps):
        raise InputError("--warm-start-steps must be in [1, --steps)")
    run_dir = Path(args.run_dir)
    if run_dir.exists() and (not run_dir.is_dir() or any(run_dir.iterdir())):
        raise InputError(f"{run_dir} exists and is not an empty folder; pick a new --run-dir")


def compose(over: list[str]):
    """The run's config as ``python -m train OVERRIDES`` composes it."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from omegaconf import OmegaConf

    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        cfg = hydra_compose(config_name="train", overrides=over)
    OmegaConf.resolve(cfg)
    return cfg


def probe(cfg, warmup: int = 2, timed: int = 3) -> float:
    """Seconds a training step of ``cfg`` takes: ``timed`` steps on one batch after ``warmup``
    (the full eq. 4.24 step, past every warm-up; the batch is rendered once, as the run's data
    processes render them beside the steps). The probe's model is freed afterwards."""
    import gc
    from dataclasses import replace

    import torch

    from train.data import batches, build_dataset
    from train.loop import _batch, _device, train_step
    from train.setup import build

    device = _device(cfg, 0)
    if cfg.trainer.threads:
        torch.set_num_threads(int(cfg.trainer.threads))
    parts = build(cfg, device)
    batch = next(batches(build_dataset(cfg.data, cfg.trainer.batch_size),
                         cfg.trainer.batch_size, 0, 0, 1, 0))
    settings = replace(parts.loss.at(10 * PAPER_STEPS, 1.0), diagnostics=False)  # past every
    # warm-up and milestone, as a step the trainer does not log
    times = []
    for step in range(warmup + timed):
        g = torch.Generator().manual_seed(step)
        t = time.perf_counter()
        images, labels = _batch(batch, cfg, parts, g)
        train_step(parts, images, labels, settings, step + 1, g)
        if device.type == "cuda":
            torch.cuda.synchronize()
        times.append(time.perf_counter() - t)
    del parts
    gc.collect()
    if device.type == "cuda":
        torch.cuda.empty_cache()
    return sorted(times[warmup:])[timed // 2]


def budget_steps(seconds: float, step_s: float) -> int:
    """The steps a training budget of ``seconds`` holds at ``step_s`` a step, 10 % kept for
    the run's start, its checkpoints and its export."""
    return max(1, int(0.9 * seconds / max(step_s, 1e-9)))


def train(cfg) -> None:
    """Train ``cfg``; a run that fails leaves no run folder behind (as ``python -m train``)."""
    from train.__main__ import _remove_if_new
    from train.loop import run

    try:
        run(cfg)
    except BaseException:
        _remove_if_new(Path(cfg.run_dir), True)
        raise


def benchmark(export: Path, run_dir: Path, limit: int, recon_limit: int) -> dict:
    """Texton extraction (model and baselines) and reconstruction of the export."""
    import eval_model
    import eval_textons

    from neuraltex.evaluation import aggregate

    seg_json, recon_json = run_dir / "benchmark.json", run_dir / "reconstruction.json"
    codes = [eval_textons.main(["--method", ",".join(("model", *BASELINES)),
                                "--checkpoint", str(export), "--limit", str(limit), "--quiet",
                                "--json", str(seg_json),
                                "--markdown", str(run_dir / "benchmark.md")]),
             eval_model.main(["--checkpoint", str(export), "--limit", str(recon_limit),
                              "--quiet", "--json", str(recon_json)])]
    if any(codes):
        raise InputError(f"the benchmark of {export} failed (see above)")
    results = json.loads(seg_json.read_text())["results"]
    seg = {m: {metric: aggregate(rows, metric) for metric in ("miou", "count_err",
                                                              "boundary_f1")}
           for m, rows in results.items()}
    return {"segmentation": seg, "images": len(results["model"]),
            "reconstruction": json.loads(recon_json.read_text())}


def report(args, command: str, plan: str, cfg, info: dict, bench: dict, total_s: float,
           device: str) -> str:
    steps, wall = int(info["steps"]), float(info["wall_s"])
    seg, rec = bench["segmentation"], bench["reconstruction"]["mean"]
    rows = ["| method | mIoU overall | mIoU hard | count error | boundary F1 |",
            "|---|---:|---:|---:|---:|"]
    for m, s in seg.items():
        rows.append(f"| {m} | {s['miou']['overall']:.3f} | {s['miou']['hard']:.3f} | "
                    f"{s['count_err']['overall']:.3f} | {s['boundary_f1']['overall']:.3f} |")
    within = "within" if total_s <= args.minutes * 60 else "OVER"
    return "\n".join([
        f"# The {cfg.model.preset} preset, recipe `{args.recipe}`, on {device}", "",
        f"`{command}`", "",
        f"- training: {steps} steps of batch {cfg.trainer.batch_size} at "
        f"{cfg.model.image_size} px in {wall:.0f} s: **{steps / max(wall, 1e-9):.2f} steps/s**"
        f" ({steps * cfg.trainer.batch_size / max(wall, 1e-9):.0f} images/s)",
        f"- steps: {plan}",
        f"- whole command: {total_s:.0f} s, {within} the {args.minutes:g} min budget", "",
        f"## Texton extraction, {_images(bench['images'])} of the held-out benchmark", "",
        *rows, "",
        f"## Reconstruction, {_images(bench['reconstruction']['images'])} at 128 px", "",
        f"PSNR {rec['psnr']:.2f} dB against a flat mean colour's {rec['psnr_constant']:.2f} dB "
        f"and the E_s masks painted with their mean colours' {rec['psnr_mask_colours']:.2f} dB;"
        f" patch SWD to the input {rec['swd_recon']:.4f}, reshuffled "
        f"{rec['swd_reshuffled']:.4f}.", ""])


def _images(n: int) -> str:
    return f"{n} image" + ("" if n == 1 else "s")


@cli_entry("train_paper_gpu")
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    check(args)
    t0 = time.time()
    budget = (args.minutes - args.eval_minutes) * 60  # seconds for the probe and training
    steps, plan = args.steps, f"{args.steps} steps asked for"
    if steps == "auto":
        step_s = probe(compose(overrides(args, 1, args.minutes)))
        left = budget - (time.time() - t0)
        steps = budget_steps(left, step_s)
        plan = (f"a probe measured {step_s:.3f} s a step: {steps} steps planned for the "
                f"{left:.0f} s left")
        print(f"train_paper_gpu: {plan}", file=sys.stderr)
        if args.recipe == "warm-start" and args.warm_start_steps >= steps:
            raise InputError(f"the budget holds {steps} steps, not more than "
                             f"--warm-start-steps {args.warm_start_steps}")
    minutes = max(budget - (time.time() - t0), 1.0) / 60  # the trainer's own clock
    cfg = compose(overrides(args, steps, minutes))
    train(cfg)
    from neuraltex.checkpoint import load_exported_model

    run_dir = Path(cfg.run_dir)
    export = run_dir / cfg.trainer.export
    _, _, info = load_exported_model(export)
    bench = benchmark(export, run_dir, args.limit, args.recon_limit)
    import torch

    device = torch.cuda.get_device_name() if args.device == "cuda" else "the CPU"
    command = " ".join(["python scripts/train_paper_gpu.py",
                        *(argv if argv is not None else sys.argv[1:])])
    text = report(args, command, plan, cfg, info, bench, time.time() - t0, device)
    write_text_atomic(run_dir / "report.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
