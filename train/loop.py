"""The training loop: build -> (generator step, critic step) x steps -> log -> checkpoint.

Runs on one process, or under ``torchrun --nproc_per_node=K -m train ...`` as DDP (gloo on
CPU, nccl on GPU). Every random draw of step s comes from a generator seeded by (seed, rank,
s) and the data of step s is fixed by s, so a resumed run continues exactly.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import torch
import torch.distributed as dist
from omegaconf import DictConfig, OmegaConf
from torch.nn.parallel import DistributedDataParallel as DDP
from tqdm import tqdm

from neuraltex.checkpoint import (
    export_model,
    load_training_checkpoint,
    save_training_checkpoint,
    set_rng_state,
)
from neuraltex.losses import ReconstructionLoss
from neuraltex.model import build_model
from train.data import batches, build_dataset
from train.logging import Logger
from train.objective import CriticObjective, GeneratorObjective, Options
from train.schedule import scheduled

_WEIGHTS = ("entropy", "compact", "csis", "texture", "gan", "pgan", "mask", "patch_size")


def _distributed() -> tuple[int, int]:
    if "RANK" not in os.environ:
        return 0, 1
    if not dist.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        dist.init_process_group(backend=backend)
    return dist.get_rank(), dist.get_world_size()


def _device(cfg: DictConfig, rank: int) -> torch.device:
    if cfg.trainer.device == "cuda":
        if not torch.cuda.is_available():
            raise RuntimeError("trainer.device=cuda but no CUDA device is available")
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", rank)))
        return torch.device("cuda")
    return torch.device("cpu")


def model_config(cfg: DictConfig) -> dict:
    m = cfg.model
    return {"preset": m.preset, "image_size": m.image_size, "estimation_size": m.estimation_size,
            "eps": m.eps, "temperature": m.temperature, "cutoff": m.cutoff}


def run(cfg: DictConfig) -> dict[str, float]:
    """Train as configured; returns the last step's logged numbers."""
    rank, world = _distributed()
    device = _device(cfg, rank)
    if cfg.trainer.threads:
        torch.set_num_threads(int(cfg.trainer.threads))
    torch.manual_seed(cfg.seed)  # identical initial weights on every rank
    run_dir = Path(cfg.run_dir)
    model, critics_d, critics_p = build_model(model_config(cfg), with_critics=True)
    L = cfg.loss
    options = Options(equivariance=L.equivariance, reshuffle=L.reshuffle, gan=L.gan,
                      mask_supervision=L.mask_supervision, reshuffle_gamma=L.reshuffle_gamma,
                      crop_size=min(critics_p.crop_size, cfg.model.image_size),
                      num_crops=critics_p.num_crops)
    recon = ReconstructionLoss(L.w_l1, L.w_lpips, L.lpips_backbone)
    critics = CriticObjective(critics_d, critics_p, options, L.r1_every, L.r1_gamma_d,
                              L.r1_gamma_dp).to(device)
    gen = GeneratorObjective(model, recon, critics, options).to(device)
    T = cfg.trainer
    opt_g = torch.optim.Adam(model.parameters(), lr=T.lr, betas=tuple(T.betas))
    opt_d = torch.optim.Adam(critics.parameters(), lr=T.d_lr, betas=tuple(T.betas))

    start = 0
    resume = run_dir / "last.pt" if T.resume == "auto" else T.resume
    if resume and Path(resume).exists():
        ck = load_training_checkpoint(resume)
        model.load_state_dict(ck["modules"]["model"])
        critics.load_state_dict(ck["modules"]["critics"])
        opt_g.load_state_dict(ck["optimizers"]["g"])
        opt_d.load_state_dict(ck["optimizers"]["d"])
        set_rng_state(ck["rng"])
        start = ck["step"]

    gen_step = DDP(gen, find_unused_parameters=True) if world > 1 else gen
    crit_step = DDP(critics, find_unused_parameters=True) if world > 1 else critics
    total_items = max(T.max_steps, 1) * T.batch_size * world
    data = batches(build_dataset(cfg.data, total_items), T.batch_size, start, rank, world,
                   cfg.data.num_workers)
    logger = Logger(run_dir, enabled=rank == 0, backbone=recon.lpips.backbone_used
                    if recon.lpips is not None else "off")
    amp = bool(T.amp) and device.type == "cuda"
    logs: dict[str, float] = {}
    t0 = time.time()
    bar = tqdm(range(start, T.max_steps), initial=start, total=T.max_steps,
               disable=rank != 0, desc="train", dynamic_ncols=True)
    for step in bar:
        g = torch.Generator().manual_seed(int(cfg.seed) * 1_000_003 + rank * 7919 + step)
        batch = next(data)
        images = batch["image"].to(device)
        labels = batch.get("mask")
        labels = _labels(labels, images, L.mask_supervision, device)
        w = {k: scheduled(L[f"w_{k}"] if k != "patch_size" else L.patch_size, step,
                          T.schedule_scale) for k in _WEIGHTS}
        existence = "all" if step < L.existence_warmup * T.schedule_scale else "sample"

        critics.requires_grad_(False)
        with torch.autocast(device.type, dtype=torch.bfloat16, enabled=amp):
            out = gen_step(images, labels, w, existence, g)
        opt_g.zero_grad(set_to_none=True)
        out.loss.backward()
        opt_g.step()
        logs = dict(out.logs)
        if options.gan:
            critics.requires_grad_(True)
            with torch.autocast(device.type, dtype=torch.bfloat16, enabled=amp):
                d_loss, d_logs = crit_step(images, out.recon.detach(),
                                           None if out.reshuffled is None
                                           else out.reshuffled.detach(), step, g)
            opt_d.zero_grad(set_to_none=True)
            d_loss.backward()
            opt_d.step()
            logs.update(d_logs)
        done = step + 1
        bar.set_postfix(recon=f"{logs['recon']:.3f}", eff=f"{logs['diag/effective']:.1f}",
                        l1=f"{logs['diag/l1']:.3f}/{logs['diag/l1_constant']:.3f}")
        if done % T.log_every == 0 or done == T.max_steps:
            logger.scalars(done, logs | {f"w/{k}": v for k, v in w.items()})
        if done % T.image_every == 0 or done == T.max_steps:
            logger.images(done, images, out)
        if rank == 0 and (done % T.ckpt_every == 0 or done == T.max_steps):
            save_training_checkpoint(
                run_dir / "last.pt", step=done, config=OmegaConf.to_container(cfg, resolve=True),
                modules={"model": model.state_dict(), "critics": critics.state_dict()},
                optimizers={"g": opt_g.state_dict(), "d": opt_d.state_dict()})
    if rank == 0 and T.export:
        info = {"steps": T.max_steps, "wall_s": round(time.time() - t0, 1),
                "lpips_backbone": logger.backbone, "mask_supervision": L.mask_supervision,
                "data": OmegaConf.to_container(cfg.data, resolve=True), "world_size": world,
                "device": device.type}
        export_model(run_dir / T.export, model.state_dict(), model_config(cfg), info)
    logger.close()
    if world > 1:
        dist.barrier()
    return logs


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
