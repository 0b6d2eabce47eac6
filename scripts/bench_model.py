"""Training speed and inference latency of the texton autoencoder on this machine.

    python scripts/bench_model.py                      # tiny: steps/s at 64 and 128 px, batch 8
    python scripts/bench_model.py --latency-presets tiny paper
    python scripts/bench_model.py --compare /work/main --recipes segmenter,full --sizes 64 128

--compare OLD_TREE times the shipped recipes' steps (``segmenter`` = experiment=
default_segmenter, ``full`` = experiment=default, eq. 4.24; see scripts/profile_train.py for
what 64 / 128 px mean) of the code in OLD_TREE (e.g. a checkout of main before the speed-ups)
and of this tree in the same run: child processes alternate old, new, old, new ... for
``--rounds`` rounds of ``--round-steps`` steps each (after ``--warmup`` steps per process), one
torch thread each; the median over rounds of each round's mean step time (wall, batch
generation included: a round of a multiple of k steps holds whole periods of a lazy term) and
their ratio are printed, for wall time and for the training process's CPU time (steadier on a
busy shared machine; a data worker's CPU is not in it). Interleaving keeps the machine's load
out of the ratios as far as it can. ``--layout shipped`` runs each tree with the torch threads
and data workers its own recipe sets (e.g. the old tree's 2 threads with the batch generated
inline, against 1 thread and a data worker), i.e. what a user of each tree got on the machine.
``--layout ddp`` runs the old tree as shipped and this tree as two data-parallel processes of one
torch thread each (``torchrun --nproc_per_node=2 -m train ... trainer.threads=1``), each on half
of the batch (the same global batch and the same items a step, train.data.StepSampler); a step's
wall time is the slower rank's, its CPU time the two ranks' sum.

Training: full steps of the training program (all losses on: reconstruction + LPIPS, entropy,
compactness, reshuffle + texture + patch GAN, equivariance consistency + transformed
reconstruction, image GAN with lazy R1 every 16 steps, critic updates) on procedural images,
timed after 2 warm-up steps; peak RSS of the process. Inference: encode + decode of one 256 px
image (best of 3), no gradients. Baselines printed for comparison: the issue's targets
(>= 2 steps/s at 64 px batch 8; <= 0.3 s encode+decode at 256 px for tiny).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import torch

HERE = Path(__file__).resolve().parent


def _images(n: int, size: int) -> torch.Tensor:
    from neuraltex.data.generator import generate

    return torch.stack([torch.from_numpy(generate(i, 0, size).image).permute(2, 0, 1)
                        for i in range(n)]).float()


def train_speed(preset: str, size: int, batch: int, steps: int) -> tuple[float, float]:
    from neuraltex.heap import keep_freed_memory
    from neuraltex.model import build_model
    from neuraltex.model_config import ModelConfig
    from neuraltex.nn_utils import adam
    from train.loss_config import LossConfig, StepSettings
    from train.objective import CriticObjective, GeneratorObjective

    keep_freed_memory()  # as the training program does (train.setup.build)
    torch.manual_seed(0)
    model, d, dp = build_model(ModelConfig(preset=preset), with_critics=True)
    loss = LossConfig(lpips_backbone="random")
    critics = CriticObjective(d, dp, loss, image_size=size)
    gen = GeneratorObjective(model, critics, loss)
    opt_g = adam(model.parameters(), lr=1e-4, betas=(0.5, 0.999))
    opt_d = adam(critics.parameters(), lr=1e-4, betas=(0.5, 0.999))
    images = _images(batch, size)
    w = StepSettings(entropy=0.08, compact=1.0, csis=0.08, texture=0.01, gan=0.1, pgan=0.1,
                     mask=1.0, patch_size=2)

    def step(i: int) -> None:
        g = torch.Generator().manual_seed(i)
        critics.requires_grad_(False)
        out = gen(images, None, w, g)
        opt_g.zero_grad()
        out.loss.backward()
        opt_g.step()
        critics.requires_grad_(True)
        loss, _ = critics(images, out.recon.detach(), out.reshuffled.detach(), i, g)
        opt_d.zero_grad()
        loss.backward()
        opt_d.step()

    for i in range(2):
        step(i + 1)  # warm-up; odd steps skip R1
    t0 = time.perf_counter()
    for i in range(steps):
        step(i)  # includes one lazy-R1 step (i = 0)
    rate = steps / (time.perf_counter() - t0)
    return rate, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def latency(preset: str, size: int) -> float:
    from neuraltex.model import build_model
    from neuraltex.model_config import ModelConfig

    torch.manual_seed(0)
    model = build_model(ModelConfig(preset=preset)).eval()
    image = _images(1, size)
    best = float("inf")
    with torch.no_grad():
        for _ in range(3):
            t0 = time.perf_counter()
            model.decode(model.encode(image).textons, (size, size))
            best = min(best, time.perf_counter() - t0)
    return best


def recipe_step_times(root: str, recipe: str, size: int, batch: int, steps: int,
                      extra: list[str], shipped: bool = False,
                      init: str | None = None, warmup: int = 1) -> list[float]:
    """(wall, CPU) seconds of each of ``steps`` training steps of a shipped recipe, built by
    the trainer code and configs of the tree ``root`` (this process's import path), after
    ``warmup`` steps; ``shipped``: with the torch threads the tree's recipe sets (else 1);
    ``init``: weights loaded with the tree's own ``train.setup.init_from`` (else the recipe's
    random init). Under torchrun (``RANK`` set) each of the ranks trains on ``batch / world``
    items as the trainer does, and every rank returns (the slowest rank's wall, the ranks'
    summed CPU)."""
    sys.path.insert(0, str(HERE))
    from profile_train import build_parts, compose, step_settings

    from train import data as train_data
    from train import loop as train_loop
    from train.loop import _batch, _distributed, train_step

    rank, world = _distributed()
    if batch % world:
        raise SystemExit(f"batch {batch} does not split over {world} ranks")
    cfg = compose(recipe, size, batch // world, extra, root=Path(root),
                  threads=None if shipped else 1)
    torch.set_num_threads(int(cfg.trainer.threads or os.cpu_count()))
    parts = build_parts(cfg, init, world)
    dataset = train_data.build_dataset(cfg.data, 1000 * batch)
    # as the tree's trainer chooses (no worker for a run read wholly from a data cache)
    workers = getattr(train_data, "data_workers", lambda _, n: n)(dataset, cfg.data.num_workers)
    data = train_data.batches(dataset, batch // world, 0, rank, world, workers)
    times = []
    for step in range(1, warmup + steps + 1):  # R1 (every 16th) falls on step 16, 32, ...
        t0, c0 = time.perf_counter(), time.process_time()
        g = torch.Generator().manual_seed(step * world + rank)
        images, labels = _batch(next(data), cfg, parts, g)
        train_step(parts, images, labels, step_settings(parts, cfg, step), step, g)
        times.append((time.perf_counter() - t0, time.process_time() - c0))
    times = times[warmup:]
    if world > 1:  # wall: the slower rank; CPU: both ranks' work
        import torch.distributed as dist

        wall, cpu = (torch.tensor([t[i] for t in times], dtype=torch.float64) for i in (0, 1))
        dist.all_reduce(wall, op=dist.ReduceOp.MAX)
        dist.all_reduce(cpu)
        times = list(zip(wall.tolist(), cpu.tolist(), strict=True))
        # a tree older than its _leave_distributed exits with its groups alive
        getattr(train_loop, "_leave_distributed", lambda: None)()
    return times


def compare(old: str, recipe: str, size: int, args) -> dict[str, tuple[float, float]]:
    """{"old": ..., "new": ...}: (wall, CPU) seconds per step of the old tree and this
    one, child processes interleaved. CPU = the training process's own CPU time (a data
    worker's is not in it), the steadier number on a shared machine."""
    runs: dict[str, list] = {"old": [], "new": []}
    for _ in range(args.rounds):
        for name, root in (("old", old), ("new", str(HERE.parent))):
            layout, launch = args.layout, [sys.executable]
            if layout == "ddp":  # the old tree as shipped, this one data-parallel
                layout = "shipped" if name == "old" else "ddp"
                if name == "new":  # a free port: another torchrun may be training beside
                    launch += ["-m", "torch.distributed.run", "--standalone",
                               "--nproc_per_node=2"]
            cmd = [*launch, str(HERE / "bench_model.py"), "--child", root, "--recipes",
                   recipe, "--sizes", str(size), "--batch", str(args.batch), "--steps",
                   str(args.round_steps), "--warmup", str(args.warmup), "--layout", layout,
                   *(["--init", args.init] if args.init else []),
                   *(["--set", *sets] if (sets := args.set + (
                       args.set_new if name == "new" else [])) else [])]
            env = {**os.environ, "PYTHONPATH": root}
            if args.layout == "one-thread":
                env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
            out = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
            if out.returncode:
                err = out.stderr if len(out.stderr) < 4000 else (  # the cause is often
                    f"{out.stderr[:1500]}\n...\n{out.stderr[-2000:]}")  # first, torchrun's last
                raise SystemExit(f"bench child failed ({root}):\n{err}")
            line = json.loads(out.stdout.strip().splitlines()[-1])
            if line["root"] != root:
                raise SystemExit(f"bench child imported {line['root']}, not {root}")
            if line["world"] != (2 if layout == "ddp" else 1):
                raise SystemExit(f"bench child ran {line['world']} processes in layout {layout}")
            times = line["times"]  # the round's mean: whole periods of any lazy term
            runs[name].append((statistics.mean(w for w, _ in times),
                               statistics.mean(c for _, c in times)))
    return {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
            for k, v in runs.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--preset", default="tiny", help="model preset of the all-losses step")
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128], help="image sides")
    ap.add_argument("--batch", type=int, default=8, help="batch size")
    ap.add_argument("--steps", type=int, default=5, help="timed steps (per round: see "
                    "--round-steps)")
    ap.add_argument("--latency-presets", nargs="*", default=["tiny"],
                    help="presets whose encode + decode latency is measured")
    ap.add_argument("--latency-size", type=int, default=256, help="latency image side")
    ap.add_argument("--compare", default=None, metavar="OLD_TREE",
                    help="time the shipped recipes of OLD_TREE's code against this tree's")
    ap.add_argument("--recipes", default="segmenter,full",
                    help="with --compare: comma list of segmenter, full")
    ap.add_argument("--rounds", type=int, default=3, help="with --compare: old/new rounds")
    ap.add_argument("--round-steps", type=int, default=2,
                    help="with --compare: steps a round (a multiple of any lazy term's k "
                    "in --set, e.g. loss.equivariance_every=4, so that each round holds "
                    "whole periods)")
    ap.add_argument("--warmup", type=int, default=4,
                    help="with --compare: untimed steps each child process runs first (a "
                    "process's first steps of each kind are up to 2x slower: allocations "
                    "and oneDNN kernels for new shapes; 4 = two periods of a k = 2 lazy "
                    "term)")
    ap.add_argument("--set", nargs="*", default=[],
                    help="with --compare: extra Hydra overrides for both trees, key=value")
    ap.add_argument("--set-new", nargs="*", default=[],
                    help="with --compare: extra Hydra overrides for this tree only (settings "
                    "the old tree does not have, e.g. loss.equivariance_every=4)")
    ap.add_argument("--layout", choices=("one-thread", "shipped", "ddp"), default="one-thread",
                    help="with --compare: one-thread = 1 torch thread in both trees (compute "
                    "per core); shipped = each tree's own recipe layout (its trainer.threads "
                    "and data.num_workers), i.e. what a user of each tree got on this machine; "
                    "ddp = the old tree as shipped, this one as 2 torchrun processes of 1 "
                    "thread, half the batch each")
    ap.add_argument("--init", default=None, metavar="WEIGHTS",
                    help="with --compare: start each tree's model from these weights, so "
                    "that the step works on the textons of a trained model rather than of a "
                    "random one; a relative path is taken inside each tree (e.g. "
                    "neuraltex/weights/default.safetensors: each tree's own shipped model), "
                    "an absolute one is loaded by both")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if not args.child:  # a child imports the tree it times (its PYTHONPATH), this one its own
        sys.path.insert(0, str(HERE.parent))
    if args.compare:
        torch.set_num_threads(1)
    if args.child:
        times = recipe_step_times(args.child, args.recipes, args.sizes[0], args.batch,
                                  args.steps, args.set, args.layout == "shipped", args.init,
                                  args.warmup)
        import train

        if os.environ.get("RANK", "0") == "0":
            print(json.dumps({"times": times, "root": str(Path(train.__file__).parents[1]),
                              "world": int(os.environ.get("WORLD_SIZE", 1))}))
        return
    if args.compare:
        layout = {"one-thread": "1 torch thread per process",
                  "shipped": "each tree's shipped threads and data workers",
                  "ddp": "the old tree's shipped threads and data workers, this tree as 2 DDP "
                         "processes of 1 thread (wall: the slower rank; CPU: both)"}[args.layout]
        start = f"weights {args.init}" if args.init else "random init"
        print(f"torch {torch.__version__}, {layout}, CPU; batch {args.batch}; {start}; "
              f"s/step: the median over {args.rounds} rounds of each round's mean over "
              f"{args.round_steps} steps after {args.warmup} warm-up steps, interleaved")
        print("| recipe | old wall s/step | new wall s/step | speed-up (wall) | old CPU s/step "
              "| new CPU s/step | speed-up (CPU) |\n|---|---:|---:|---:|---:|---:|---:|")
        for recipe in args.recipes.split(","):
            for size in args.sizes:
                r = compare(args.compare, recipe, size, args)
                cells = []
                for i in (0, 1):
                    old, new = r["old"][i], r["new"][i]
                    cells += [f"{old:.3f}", f"{new:.3f}", f"**{old / new:.2f}x**"]
                print(f"| {recipe} {size} px | " + " | ".join(cells) + " |", flush=True)
        return
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, CPU")
    print(f"training steps ({args.preset}, batch {args.batch}, all losses): target >= 2 steps/s "
          "at 64 px")
    for size in args.sizes:
        rate, rss = train_speed(args.preset, size, args.batch, args.steps)
        print(f"  {size:>4} px: {rate:6.2f} steps/s, peak RSS {rss:6.0f} MB")
    print(f"encode + decode latency at {args.latency_size} px (target <= 0.3 s for tiny)")
    for preset in args.latency_presets:
        print(f"  {preset:>6}: {latency(preset, args.latency_size):6.3f} s")


if __name__ == "__main__":
    main()
