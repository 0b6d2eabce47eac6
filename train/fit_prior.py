"""``python -m train.fit_prior``: meta-learn where ``neuraltex fit`` starts tuning G (Reptile).

``neuraltex fit`` tunes a copy of the decoder G to one texture (:mod:`neuraltex.fit`). This
learns a start for that tuning (Nichol et al. 2018, "On first-order meta-learning
algorithms"): draw a procedural texture, run ``--inner-steps`` steps of the fit's own tuning
from the current start phi (G, appearance features and colour offsets, the same crops, loss
and learning rates), then move phi toward the tuned G,

    phi <- phi + eps_i (G_tuned - phi),   eps_i = eps (1 - i / iterations),

so phi becomes a point from which a few steps reach any texture's G. The result is written
beside the weights as their fit prior (:mod:`neuraltex.fit_prior`), which ``fit`` then starts
from. The run state (phi, the iteration, the random stream) is saved every
``--save-every`` iterations and at Ctrl-C; the same command resumes it. A state belongs to
its weights (their SHA-256 names the default state file and is part of its settings), so a
prior for other weights never resumes, or finishes as, another model's run.

Examples:
    python -m train.fit_prior                                   # the shipped prior's recipe
    python -m train.fit_prior --iterations 3 --inner-steps 2 --size 64 --out /tmp/p.safetensors
"""

from __future__ import annotations

import argparse
import copy
import os
import sys
import time
from pathlib import Path

import torch

from neuraltex.errors import InputError, one_line
from neuraltex.fileio import atomic_path, file_sha256, load_weights_only
from neuraltex.fit import FitSettings, choose_segments, first_offsets, tuning, tuning_step
from neuraltex.fit_prior import prior_path, save_prior, start_generator
from neuraltex.model import DEFAULT_MODEL, load_model
from neuraltex.tuned_decoder import ColourOffsetGenerator


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m train.fit_prior",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--weights", type=Path, default=DEFAULT_MODEL,
                    help="the model whose fit prior is learned (default: the shipped one)")
    ap.add_argument("--out", type=Path,
                    help="where to write the prior (default: beside --weights, "
                    "NAME.fit_prior.safetensors)")
    ap.add_argument("--state", type=Path,
                    help="run state, saved as it goes and resumed from (default "
                    "runs/fit_prior/<the first 16 hex digits of --weights' SHA-256>.pt: a run "
                    "resumes only its own model's state)")
    ap.add_argument("--tasks", type=int, default=48,
                    help="procedural textures drawn from (default 48)")
    ap.add_argument("--task-seed", type=int, default=7,
                    help="stream of the procedural generator the textures come from "
                    "(default 7: not the benchmark's)")
    ap.add_argument("--size", type=int, default=256, help="texture side, pixels (default 256)")
    ap.add_argument("--iterations", type=int, default=400,
                    help="meta-iterations, one texture each (default 400)")
    ap.add_argument("--inner-steps", type=int, default=30,
                    help="fit tuning steps per iteration (default 30)")
    ap.add_argument("--epsilon", type=float, default=0.5,
                    help="Reptile step at the start, annealed to 0 (default 0.5)")
    ap.add_argument("--seed", type=int, default=7,
                    help="seed of the draws and crops (default 7, the shipped prior's)")
    ap.add_argument("--save-every", type=int, default=20,
                    help="iterations between saves of the run state (default 20)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    args = ap.parse_args(argv)
    for name in ("tasks", "size", "iterations", "inner_steps", "save_every", "threads"):
        if getattr(args, name) < 1:
            ap.error(f"--{name.replace('_', '-')} must be at least 1")
    if not 0 < args.epsilon <= 1:
        ap.error("--epsilon must be in (0, 1]")
    if not 32 <= args.size <= 1024:
        ap.error("--size must be between 32 and 1024")
    return args


class Tasks:
    """The procedural textures of the run, each prepared once as the fit prepares an image
    (segments, textons, first colour offsets) when first drawn."""

    def __init__(self, model, count: int, seed: int, size: int, cfg: FitSettings) -> None:
        self.model, self.count, self.seed, self.size, self.cfg = model, count, seed, size, cfg
        self.ready: dict[int, tuple] = {}

    def __getitem__(self, i: int) -> tuple:
        if i not in self.ready:
            from neuraltex.data.generator import generate

            image = torch.from_numpy(generate(i, self.seed, self.size).image)
            image = image.permute(2, 0, 1).contiguous()  # (3, H, W)
            _, textons, labels = choose_segments(self.model, image, self.cfg.segmenter,
                                                 self.cfg.max_textons)
            self.ready[i] = (image, textons, first_offsets(self.model, image, textons, labels))
        return self.ready[i]


def reptile_iteration(model, phi: torch.nn.Module, task: tuple, cfg: FitSettings,
                      steps: int, eps: float, rng: torch.Generator) -> tuple[float, float]:
    """One Reptile update of the start ``phi`` (G) in place; returns the tuning's first and
    last loss."""
    image, textons, offsets = task
    G = ColourOffsetGenerator(copy.deepcopy(phi)).eval()  # eval: keep BN stats
    current, opt = tuning(G, textons, offsets, cfg)
    losses = [tuning_step(model, G, image, current(), opt, cfg, rng) for _ in range(steps)]
    with torch.no_grad():
        for p, q in zip(phi.parameters(), G.generator.parameters(), strict=True):
            p.add_(eps * (q - p))
    return losses[0], losses[-1]


def run(args: argparse.Namespace) -> Path:
    from tqdm import tqdm

    torch.set_num_threads(args.threads)
    model = load_model(args.weights)
    args.weights_sha256 = file_sha256(args.weights)
    if args.state is None:
        args.state = Path("runs/fit_prior") / f"{args.weights_sha256[:16]}.pt"
    phi = start_generator(model, use_prior=False)  # (re)learned from the model's own G
    cfg = FitSettings(steps=args.inner_steps)
    rng = torch.Generator().manual_seed(args.seed)
    first = 0
    if args.state.is_file():
        state = load_weights_only(args.state, InputError, "fit prior run state")
        if state.get("recipe") != recipe(args):
            raise InputError(f"{args.state}: a run for other weights or settings; remove "
                             "it or pass another --state")
        phi.load_state_dict(state["phi"])
        rng.set_state(state["rng"])
        first = int(state["iteration"])
    tasks = Tasks(model, args.tasks, args.task_seed, args.size, cfg)
    bar = tqdm(range(first, args.iterations), initial=first, total=args.iterations,
               desc="fit prior", unit="it")
    i, at = first, rng.get_state()
    try:
        for i in bar:
            at = rng.get_state()  # a resume redoes iteration i from here
            task = tasks[int(torch.randint(args.tasks, (1,), generator=rng))]
            eps = args.epsilon * (1 - i / args.iterations)
            a, b = reptile_iteration(model, phi, task, cfg, args.inner_steps, eps, rng)
            bar.set_postfix(loss=f"{a:.3f}->{b:.3f}")
            if (i + 1) % args.save_every == 0:
                save_state(args, phi, rng, i + 1)
        i = args.iterations
    except KeyboardInterrupt:
        rng.set_state(at)
        save_state(args, phi, rng, i)
        raise
    out = args.out or prior_path(args.weights)
    save_prior(out, model, dict(phi.named_parameters()), {**recipe(args), "iterations_done": i})
    save_state(args, phi, rng, i)
    return out


def recipe(args: argparse.Namespace) -> dict:
    """The settings a run state belongs to (a resume must not change them)."""
    return {k: getattr(args, k, None)  # weights_sha256: set by run() once the file is read
            for k in ("weights_sha256", "tasks", "task_seed", "size", "iterations",
                      "inner_steps", "epsilon", "seed")}


def save_state(args: argparse.Namespace, phi: torch.nn.Module, rng: torch.Generator,
               iteration: int) -> None:
    with atomic_path(args.state) as tmp:
        torch.save({"phi": phi.state_dict(), "rng": rng.get_state(), "iteration": iteration,
                    "recipe": recipe(args)}, tmp)


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    start = time.perf_counter()
    try:
        out = run(args)
    except InputError as exc:
        print(f"train.fit_prior: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\ntrain.fit_prior: interrupted; state saved in {args.state}", file=sys.stderr)
        return 130
    print(f"wrote {out} ({os.path.getsize(out) / 1024:.0f} KB) in "
          f"{time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
