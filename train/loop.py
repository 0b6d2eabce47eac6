"""The training loop: build -> restore -> (generator step, critic step) x steps -> log ->
checkpoint -> export.

Runs on one process, or under ``torchrun --nproc_per_node=K -m train ...`` as DDP (gloo on
CPU, nccl on GPU). Every random draw of step s comes from a generator seeded by (seed, rank,
s) and the data of step s is fixed by s, so a resumed run continues exactly.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from dataclasses import replace
from pathlib import Path

import torch
import torch.distributed as dist
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

from neuraltex.checkpoint import save_training_checkpoint
from neuraltex.errors import InputError
from train.data import batches, build_dataset, crop_batch, data_workers
from train.export import export
from train.logging import Logger
from train.loss_config import StepSettings
from train.objective import Outputs
from train.schedule import scheduled
from train.setup import Parts, Progress, build, check_inputs, restore


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during training, after the checkpoint of the last finished step was saved."""

    def __init__(self, step: int, checkpoint: Path | None) -> None:
        super().__init__(step)
        self.step, self.checkpoint = step, checkpoint


def run(cfg: DictConfig) -> dict[str, float]:
    """Train as configured; returns the last step's logged numbers. Ctrl-C saves a
    checkpoint of the last finished step and raises :class:`Interrupted`."""
    check_inputs(cfg.trainer, Path(cfg.run_dir))
    rank, world = _distributed()
    try:
        return _run(cfg, rank, world)
    finally:  # every gloo thread joined before the interpreter exits (else: SIGABRT)
        _leave_distributed()


def _run(cfg: DictConfig, rank: int, world: int) -> dict[str, float]:
    device = _device(cfg, rank)
    if cfg.trainer.threads:
        torch.set_num_threads(int(cfg.trainer.threads))
    torch.manual_seed(cfg.seed)  # identical initial weights on every rank
    T, run_dir = cfg.trainer, Path(cfg.run_dir)
    parts = build(cfg, device, world)
    progress = restore(parts, T, run_dir)
    dataset = build_dataset(cfg.data, max(T.max_steps, 1) * T.batch_size * world)
    data = batches(dataset, T.batch_size, progress.start, rank, world,
                   data_workers(dataset, cfg.data.num_workers))
    lpips = parts.gen.recon.lpips
    logger = Logger(run_dir, enabled=rank == 0,
                    backbone=lpips.backbone_used if lpips is not None else "off")
    t0, done, logs = time.time(), progress.start, {}
    bar = tqdm(range(progress.start, T.max_steps), initial=progress.start, total=T.max_steps,
               disable=rank != 0, desc="train", dynamic_ncols=True)
    ctrl_c = _CtrlC()
    try:
        done, logs = _steps(cfg, parts, progress, data, logger, bar, (rank, world), t0, ctrl_c)
    finally:
        ctrl_c.restore()
    if ctrl_c.pressed:  # the last finished step was checkpointed
        bar.close()
        logger.close()
        saved = Path(cfg.run_dir) / "last.pt" if rank == 0 and done > progress.start else None
        raise Interrupted(done, saved)
    if rank == 0 and T.export:
        export(parts, cfg, dataset, done, progress.wall_before + time.time() - t0, world,
               logger.backbone, progress)
    logger.close()
    if world > 1:  # no rank leaves while rank 0 exports
        dist.barrier()
    return logs


def _steps(cfg: DictConfig, parts: Parts, progress: Progress, data, logger: Logger, bar,
           ranks: tuple[int, int], t0: float, ctrl_c: _CtrlC) -> tuple[int, dict[str, float]]:
    """The training steps of ``bar`` until the end, the time limit or Ctrl-C; returns (steps
    done, the last step's logs)."""
    (rank, world), device = ranks, parts.device
    T, done, logs = cfg.trainer, progress.start, {}
    for step in bar:
        g = torch.Generator().manual_seed(int(cfg.seed) * 1_000_003 + rank * 7919 + step)
        images, labels = _batch(next(data), cfg, parts, g)
        shown = step + 1 == T.max_steps or any((step + 1) % k == 0
                                                for k in (T.log_every, T.image_every))
        settings = replace(parts.loss.at(step, T.schedule_scale), diagnostics=shown)
        _set_lr(parts, T, step)
        out, logs = train_step(parts, images, labels, settings, step, g)
        done = step + 1
        stop = _should_stop(T.max_minutes, t0, world, device, ctrl_c.pressed)
        bar.set_postfix(_progress(logs))
        if done % T.log_every == 0 or done == T.max_steps:
            logger.scalars(done, logs | {f"w/{k}": v for k, v in settings.scalars().items()}
                           | {"w/lr": parts.opt_g.param_groups[0]["lr"]})
        if done % T.image_every == 0 or done == T.max_steps:
            logger.images(done, images, out)
        if rank == 0 and (done % T.ckpt_every == 0 or done == T.max_steps or stop):
            _checkpoint(parts, cfg, done, progress.wall_before + time.time() - t0, progress)
        if stop:  # every rank measures its own clock; rank 0 decides for all
            break
    return done, logs


class _CtrlC:
    """The first Ctrl-C (SIGINT) only sets ``pressed``: the loop finishes its step, saves a
    checkpoint and stops; a second one interrupts at once."""

    def __init__(self) -> None:
        self.pressed = False
        self.previous = signal.getsignal(signal.SIGINT)
        self.installed = threading.current_thread() is threading.main_thread()
        if self.installed:
            signal.signal(signal.SIGINT, self._press)

    def _press(self, signum, frame) -> None:
        self.pressed = True
        signal.signal(signal.SIGINT, self.previous)

    def restore(self) -> None:
        if self.installed:
            signal.signal(signal.SIGINT, self.previous)


def train_step(parts: Parts, images: torch.Tensor, labels: torch.Tensor | None,
               settings: StepSettings, step: int,
               g: torch.Generator) -> tuple[Outputs, dict[str, float]]:
    """One generator step (eq. 4.24), then, with the GAN on and after the segmenter warm-up,
    one critic step; returns the generator outputs and the logged numbers."""
    autocast = dict(device_type=parts.device.type, dtype=torch.bfloat16, enabled=parts.amp)
    parts.critics.requires_grad_(False)
    with torch.autocast(**autocast):
        out = parts.gen_step(images, labels, settings, g)
    parts.opt_g.zero_grad(set_to_none=True)
    out.loss.backward()
    parts.opt_g.step()
    logs = dict(out.logs)
    if parts.loss.gan and not settings.segmenter_only:
        parts.critics.requires_grad_(True)
        with torch.autocast(**autocast):
            reshuffled = None if out.reshuffled is None else out.reshuffled.detach()
            d_loss, d_logs = parts.crit_step(images, out.recon.detach(), reshuffled, step, g,
                                             settings.reshuffle)
        parts.opt_d.zero_grad(set_to_none=True)
        d_loss.backward()
        parts.opt_d.step()
        logs.update(d_logs)
    return out, logs


def _batch(batch: dict, cfg: DictConfig, parts: Parts, g: torch.Generator):
    """(images (B, 3, h, w), labels (B, h, w) or None) of one step, cropped, on the device."""
    images, labels = crop_batch(batch["image"], batch.get("mask"), cfg.data.crop, g)
    images = images.to(parts.device)
    return images, _labels(labels, images, parts.loss.mask_supervision, parts.device)


def _set_lr(parts: Parts, T: DictConfig, step: int) -> None:
    factor = scheduled(T.lr_factor, step)  # run steps, not scaled paper steps
    for opt, lr in ((parts.opt_g, T.lr), (parts.opt_d, T.d_lr)):
        for group in opt.param_groups:
            group["lr"] = lr * factor


def _checkpoint(parts: Parts, cfg: DictConfig, done: int, wall_s: float,
                progress: Progress) -> None:
    save_training_checkpoint(
        Path(cfg.run_dir) / "last.pt", step=done,
        config=OmegaConf.to_container(cfg, resolve=True),
        modules={"model": parts.model.state_dict(), "critics": parts.critics.state_dict()},
        optimizers={"g": parts.opt_g.state_dict(), "d": parts.opt_d.state_dict()},
        extra={"wall_s": wall_s, "init": progress.init})


def _distributed() -> tuple[int, int]:
    if "RANK" not in os.environ:
        return 0, 1
    if not dist.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        dist.init_process_group(backend=backend)
    return dist.get_rank(), dist.get_world_size()


def _leave_distributed() -> None:
    """Destroys the process groups (the default one and any made from it, such as the
    cross-rank BatchNorm's). A process that exits with a gloo group alive can abort in its
    destructor ("terminate called without an active exception"), failing a finished run."""
    if dist.is_available() and dist.is_initialized():
        dist.destroy_process_group()


def _device(cfg: DictConfig, rank: int) -> torch.device:
    if cfg.trainer.device == "cuda":
        if not torch.cuda.is_available():
            raise InputError("trainer.device=cuda but no CUDA device is available here "
                             "(trainer.device=cpu trains on the CPU)")
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", rank)))
        return torch.device("cuda")
    return torch.device("cpu")


def _progress(logs: dict[str, float]) -> dict[str, str]:
    out = {k: f"{logs[k]:.3f}" for k in ("recon", "mask") if k in logs}
    if "diag/effective" in logs:
        out["eff"] = f"{logs['diag/effective']:.1f}"
    if "diag/l1" in logs:
        const = logs.get("diag/l1_constant")  # only on logged steps
        out["l1"] = f"{logs['diag/l1']:.3f}" + (f"/{const:.3f}" if const is not None else "")
    return out


def _should_stop(max_minutes, t0: float, world: int, device, pressed: bool) -> bool:
    """``trainer.max_minutes`` reached or Ctrl-C pressed (rank 0 decides for every rank)."""
    late = bool(max_minutes) and time.time() - t0 > 60 * max_minutes
    if world == 1:
        return late or pressed
    flag = torch.tensor([float(late or pressed)], device=device)
    dist.broadcast(flag, src=0)
    return bool(flag.item())


def _labels(labels, images, mode: str, device) -> torch.Tensor | None:
    if mode == "gt":
        if labels is None:
            raise RuntimeError("loss.mask_supervision=gt needs data with ground-truth masks")
        return labels.to(device)
    if mode == "pseudo":
        from neuraltex.baselines import get_segmenter

        segment = get_segmenter("felzenszwalb")
        return torch.stack([torch.from_numpy(segment(im.permute(1, 2, 0).cpu().numpy()))
                            for im in images]).long().to(device)
    return None
