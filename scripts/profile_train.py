"""Where the time of a training step goes: torch.profiler shares of each part of a step.

    python scripts/profile_train.py                          # both recipes, 64 and 128 px
    python scripts/profile_train.py --recipes segmenter --sizes 128 --steps 3
    python scripts/profile_train.py --markdown docs/training_speed_profile.md

Recipes (the shipped ones, MODEL.md, built by the trainer's own code from the Hydra configs):
``segmenter`` = ``experiment=default_segmenter`` (E_s alone, Hungarian-matched mask loss);
``full`` = ``experiment=default`` (eq. 4.24 with loss/cpu around a frozen E_s, then the critic
step). "64 px" / "128 px" is the side of the images a step trains on: for ``segmenter`` the
model's ``image_size`` (estimation at half of it), for ``full`` the crop of the 128 px images
(128 = no crop). Every labelled part is timed exclusively (nested labels are subtracted), so
the shares add up to 100 % with "other" (Python glue, ops outside any label). The backward
pass of a step is one row: autograd runs it outside the forward labels.

Extra trainer overrides (e.g. ``--set trainer.fast=false``) compare settings.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import sys
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path
from unittest import mock

import torch

ROOT = Path(__file__).resolve().parents[1]

RECIPES = {"segmenter": "default_segmenter", "full": "default"}


def compose(recipe: str, size: int, batch: int, extra: list[str], root: Path = ROOT,
            threads: int | None = 1):
    """The recipe's resolved Hydra config at a step side ``size`` (see the module doc), from
    the configs of the tree ``root``; ``trainer.threads`` set to ``threads`` (None: the
    recipe's own)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    over = [f"experiment={RECIPES[recipe]}", f"trainer.batch_size={batch}",
            "trainer.init_from=null", "trainer.init_parts={}", "trainer.resume=null",
            "run_dir=/nonexistent"]
    if threads and not any(o.startswith("trainer.threads=") for o in extra):
        over.append(f"trainer.threads={threads}")  # unless the caller sets it
    if recipe == "segmenter":
        over += [f"model.image_size={size}", f"model.estimation_size={size // 2}"]
    else:
        over += [f"data.crop={size}" if size < 128 else "data.crop=null"]
    with initialize_config_dir(config_dir=str(root / "configs"), version_base="1.3"):
        return hydra_compose(config_name="train", overrides=over + extra)


LABELS = {"step", "data generation", "backward", "optimizer"}  # and label_parts' names


def _labelled(fn, name: str):
    LABELS.add(name)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with torch.profiler.record_function(name):
            return fn(*args, **kwargs)
    return wrapper


def label_parts(parts, stack: contextlib.ExitStack) -> None:
    """Wrap the parts of a step in record_function labels (modules: their forward; functions:
    at the place the objective calls them, restored when ``stack`` closes)."""
    import neuraltex.model as model_mod
    import train.mask_supervision as ms
    import train.objective as obj

    m, seg = parts.model, parts.model.segmenter
    modules = {"E_FC": m.encoder, "G": m.generator, "E_s backbone": seg.backbone,
               "E_s pixel decoder": seg.pixel_decoder, "E_s mask head": seg.mask_head,
               "critic D": parts.critics.image, "critic D_p": parts.critics.patch,
               "loss recon (L1+LPIPS)": parts.gen.recon}
    if seg.anchor_prior is not None:
        modules["E_s anchor prior"] = seg.anchor_prior
    for name, mod in modules.items():
        mod.forward = _labelled(mod.forward, name)
    for layer in seg.layers:
        layer.forward = _labelled(layer.forward, "E_s transformer layers")
    for where, attr, name in [
        (model_mod, "estimate_textons", "estimation"), (obj, "estimate_textons", "estimation"),
        (model_mod, "splat", "splatting"), (obj, "mask_supervision_loss", "loss mask"),
        (ms, "linear_sum_assignment", "E_s matching (Hungarian)"),
        (ms, "segment_stats", "loss mask: pairwise cost"),  # older trees: pairwise_dice_bce
        (ms, "pairwise_dice_bce", "loss mask: pairwise cost"),
        (obj, "entropy_loss", "loss entropy"), (obj, "compactness_loss", "loss compactness"),
        (obj, "soft_reshuffle", "reshuffle"), (obj, "sliced_wasserstein_patches", "loss texture"),
        (obj, "consistency_loss", "loss csis"), (obj, "warp_images", "warp (equivariance)"),
        (obj, "_diagnostics", "diagnostics"), (obj, "d_r1_loss", "loss R1"),
    ]:
        if hasattr(where, attr):  # a part another tree does not have is not labelled
            stack.enter_context(mock.patch.object(where, attr,
                                                  _labelled(getattr(where, attr), name)))


def one_step(parts, cfg, data, step: int, settings) -> None:
    from train.loop import _batch, train_step

    rf = torch.profiler.record_function
    with rf("step"):
        g = torch.Generator().manual_seed(step)
        with rf("data generation"):
            batch = next(data)
        images, labels = _batch(batch, cfg, parts, g)
        train_step(parts, images, labels, settings, step, g)


def label_step_phases(stack: contextlib.ExitStack) -> None:
    """Backward passes and optimizer steps of train_step, labelled through torch's own calls
    (restored when ``stack`` closes)."""
    rf = torch.profiler.record_function
    backward, step = torch.Tensor.backward, torch.optim.Adam.step

    def labelled_backward(self, *a, **k):
        with rf("backward"):
            return backward(self, *a, **k)

    def labelled_step(self, *a, **k):
        with rf("optimizer"):
            return step(self, *a, **k)

    stack.enter_context(mock.patch.object(torch.Tensor, "backward", labelled_backward))
    stack.enter_context(mock.patch.object(torch.optim.Adam, "step", labelled_step))


def exclusive_times(prof, labels: set[str]) -> dict[str, float]:
    """Milliseconds per label, each label's time minus its nearest labelled descendants'."""
    out: dict[str, float] = defaultdict(float)

    def labelled_below(ev) -> float:
        t = 0.0
        for ch in ev.cpu_children:
            t += ch.cpu_time_total if ch.name in labels else labelled_below(ch)
        return t

    for ev in prof.events():
        if ev.name in labels:
            out[ev.name] += (ev.cpu_time_total - labelled_below(ev)) / 1e3
    return out


def step_settings(parts, cfg, step: int = 0):
    """The settings of step 10,000 + ``step``, past every warm-up, as the trainer sets them on
    a step it does not log (no full diagnostics; trees before they were optional compute them
    on every step). Lazy terms (``loss.*_every``) fall on every k-th ``step``."""
    settings = parts.loss.at(10_000 + step, cfg.trainer.schedule_scale)
    if hasattr(settings, "diagnostics"):
        settings = replace(settings, diagnostics=False)
    return settings


def build_parts(cfg, init: str | None = None, world: int = 1):
    """The trainer's parts of ``cfg`` on the CPU (seed 0), the model started from ``init``
    weights when given (else the recipe's random init), with the imported tree's own code;
    DDP-wrapped for ``world`` > 1 ranks (under torchrun)."""
    from train.setup import build, init_from

    torch.manual_seed(0)
    parts = build(cfg, torch.device("cpu"), world)
    if init:
        init_from(parts.model, init, {})
    return parts


def profile(recipe: str, size: int, batch: int, steps: int, extra: list[str],
            root: Path = ROOT, init: str | None = None):
    """(ms per part per step, wall s per step) of ``steps`` profiled steps after a warm-up;
    ``init``: weights the model starts from (else the recipe's random init)."""
    from train.data import batches, build_dataset

    cfg = compose(recipe, size, batch, extra, root)
    torch.set_num_threads(int(cfg.trainer.threads or 1))  # 1, or --set trainer.threads=N
    parts = build_parts(cfg, init)
    stack = contextlib.ExitStack()
    label_parts(parts, stack)
    dataset = build_dataset(cfg.data, 1000 * batch)
    data = batches(dataset, batch, 0, 0, 1, cfg.data.num_workers)
    one_step(parts, cfg, data, 1, step_settings(parts, cfg, 1))  # warm-up (odd: no lazy R1)
    with stack, torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CPU]) as prof:
        t0 = time.perf_counter()
        for s in range(steps):
            one_step(parts, cfg, data, s + 2, step_settings(parts, cfg, s + 2))
        wall = (time.perf_counter() - t0) / steps
    times = exclusive_times(prof, LABELS)
    return {k: v / steps for k, v in times.items()}, wall


def table(results: dict[str, tuple[dict[str, float], float]]) -> str:
    cols = list(results)
    rows = sorted({k for r, _ in results.values() for k in r} - {"step"},
                  key=lambda k: -max(r.get(k, 0) / _total(r) for r, _ in results.values()))
    lines = ["| part | " + " | ".join(cols) + " |", "|---|" + "---:|" * len(cols)]
    for k in rows:
        cells = []
        for c in cols:
            r = results[c][0]
            cells.append(f"{100 * r[k] / _total(r):.1f} %" if k in r else "")
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    lines.append("| **other** (outside labels) | " + " | ".join(
        f"{100 * results[c][0]['step'] / _total(results[c][0]):.1f} %" for c in cols) + " |")
    lines.append("| **step (profiled ms)** | " + " | ".join(
        f"{_total(results[c][0]):.0f}" for c in cols) + " |")
    lines.append("| **step (wall s, profiler on)** | " + " | ".join(
        f"{results[c][1]:.3f}" for c in cols) + " |")
    return "\n".join(lines)


def _total(r: dict[str, float]) -> float:
    """The step's profiled time: its own exclusive rest plus every labelled part."""
    return sum(r.values())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--recipes", default="segmenter,full",
                    help="comma list of segmenter, full")
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128],
                    help="image sides a step trains on")
    ap.add_argument("--batch", type=int, default=8, help="batch size (the shipped 8)")
    ap.add_argument("--steps", type=int, default=3, help="profiled steps after one warm-up")
    ap.add_argument("--set", nargs="*", default=[], help="extra Hydra overrides, key=value")
    ap.add_argument("--init", default=None, metavar="WEIGHTS",
                    help="start the model from these weights (e.g. neuraltex/weights/"
                    "default.safetensors): a trained E_s's textons, as stage 2 splats them, "
                    "instead of a random model's")
    ap.add_argument("--markdown", default=None, help="also write the table to this file")
    ap.add_argument("--root", default=None, help="profile the code and configs of another "
                    "checkout (e.g. main before the speed-ups) instead of this one")
    args = ap.parse_args(argv)
    root = Path(args.root).resolve() if args.root else ROOT
    sys.path.insert(0, str(root))
    results, threads = {}, set()
    with contextlib.ExitStack() as stack:
        stack.callback(torch.set_num_threads, torch.get_num_threads())  # the caller's, after
        label_step_phases(stack)
        for recipe in args.recipes.split(","):
            for size in args.sizes:
                name = f"{recipe} {size} px"
                results[name] = profile(recipe, size, args.batch, args.steps, args.set, root,
                                        args.init)
                threads.add(torch.get_num_threads())  # as the profile set them
                print(f"{name}: {results[name][1]:.3f} s/step", file=sys.stderr)
    command = "python scripts/profile_train.py " + " ".join(argv if argv is not None
                                                             else sys.argv[1:])
    import train

    tree = Path(train.__file__).resolve().parents[1]
    text = (f"Share of a training step per part (`{command.strip()}`, code of {tree}; torch "
            f"{torch.__version__}, {'/'.join(map(str, sorted(threads)))} thread(s), "
            f"batch {args.batch}, mean of {args.steps} steps)."
            f"\n\n{table(results)}\n")
    print(text)
    if args.markdown:
        from neuraltex.fileio import write_text_atomic

        write_text_atomic(args.markdown, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
