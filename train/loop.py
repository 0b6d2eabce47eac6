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
from neuraltex.consistency import ConsistencyWeights
from neuraltex.losses import ReconstructionLoss
from neuraltex.model import build_model
from train.data import batches, build_dataset, crop_batch
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
    return {"preset": m.preset, "num_queries": m.get("num_queries"),
            "anchor_prior": m.get("anchor_prior"), "image_size": m.image_size,
            "estimation_size": m.estimation_size, "eps": m.eps, "temperature": m.temperature,
            "cutoff": m.cutoff}


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
                      num_crops=critics_p.num_crops,
                      csis_weights=ConsistencyWeights(**L.csis_lambda),
                      csis_reduce=L.csis_reduce)
    recon = ReconstructionLoss(L.w_l1, L.w_lpips, L.lpips_backbone)
    critics = CriticObjective(critics_d, critics_p, options, L.r1_every, L.r1_gamma_d,
                              L.r1_gamma_dp).to(device)
    gen = GeneratorObjective(model, recon, critics, options).to(device)
    T = cfg.trainer
    for name in T.freeze or ():  # e.g. [segmenter]: fine-tune the rest around a fixed E_s
        getattr(model, name).requires_grad_(False)
    trainable = [p for p in model.parameters() if p.requires_grad]
    opt_g = torch.optim.Adam(trainable, lr=T.lr, betas=tuple(T.betas))
    opt_d = torch.optim.Adam(critics.parameters(), lr=T.d_lr, betas=tuple(T.betas))

    start, wall_before, init = 0, 0.0, {}
    resume = run_dir / "last.pt" if T.resume == "auto" else T.resume
    if resume and Path(resume).exists():
        ck = load_training_checkpoint(resume)
        model.load_state_dict(ck["modules"]["model"])
        critics.load_state_dict(ck["modules"]["critics"])
        opt_g.load_state_dict(ck["optimizers"]["g"])
        opt_d.load_state_dict(ck["optimizers"]["d"])
        set_rng_state(ck["rng"])
        start = ck["step"]
        wall_before = float(ck.get("extra", {}).get("wall_s", 0.0))
        init = ck.get("extra", {}).get("init", {})
    elif T.init_from or T.init_parts:
        init = _init_from(model, T.init_from, T.init_parts)

    gen_step = DDP(gen, find_unused_parameters=True) if world > 1 else gen
    crit_step = DDP(critics, find_unused_parameters=True) if world > 1 else critics
    total_items = max(T.max_steps, 1) * T.batch_size * world
    dataset = build_dataset(cfg.data, total_items)
    data = batches(dataset, T.batch_size, start, rank, world, cfg.data.num_workers)
    logger = Logger(run_dir, enabled=rank == 0, backbone=recon.lpips.backbone_used
                    if recon.lpips is not None else "off")
    amp = bool(T.amp) and device.type == "cuda"
    logs: dict[str, float] = {}
    t0 = time.time()
    done = start
    bar = tqdm(range(start, T.max_steps), initial=start, total=T.max_steps,
               disable=rank != 0, desc="train", dynamic_ncols=True)
    for step in bar:
        g = torch.Generator().manual_seed(int(cfg.seed) * 1_000_003 + rank * 7919 + step)
        batch = next(data)
        images, labels = crop_batch(batch["image"], batch.get("mask"), cfg.data.crop, g)
        images = images.to(device)
        labels = _labels(labels, images, L.mask_supervision, device)
        w = {k: scheduled(L[f"w_{k}"] if k != "patch_size" else L.patch_size, step,
                          T.schedule_scale) for k in _WEIGHTS}
        existence = "all" if step < L.existence_warmup * T.schedule_scale else "sample"
        factor = scheduled(T.lr_factor, step)  # run steps, not scaled paper steps
        for opt, lr in ((opt_g, T.lr), (opt_d, T.d_lr)):
            for group in opt.param_groups:
                group["lr"] = lr * factor
        segmenter_only = step < L.segmenter_warmup * T.schedule_scale

        critics.requires_grad_(False)
        with torch.autocast(device.type, dtype=torch.bfloat16, enabled=amp):
            out = gen_step(images, labels, w, existence, g, segmenter_only)
        opt_g.zero_grad(set_to_none=True)
        out.loss.backward()
        opt_g.step()
        logs = dict(out.logs)
        if options.gan and not segmenter_only:
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
        out_of_time = _out_of_time(T.max_minutes, t0, world, device)
        bar.set_postfix(_progress(logs))
        if done % T.log_every == 0 or done == T.max_steps:
            logger.scalars(done, logs | {f"w/{k}": v for k, v in w.items()}
                           | {"w/lr": opt_g.param_groups[0]["lr"]})
        if done % T.image_every == 0 or done == T.max_steps:
            logger.images(done, images, out)
        if rank == 0 and (done % T.ckpt_every == 0 or done == T.max_steps or out_of_time):
            save_training_checkpoint(
                run_dir / "last.pt", step=done, config=OmegaConf.to_container(cfg, resolve=True),
                modules={"model": model.state_dict(), "critics": critics.state_dict()},
                optimizers={"g": opt_g.state_dict(), "d": opt_d.state_dict()},
                extra={"wall_s": wall_before + time.time() - t0, "init": init})
        if out_of_time:  # every rank measures its own clock; rank 0 decides for all
            break
    if rank == 0 and T.export:
        info = {"steps": done, "wall_s": round(wall_before + time.time() - t0, 1),
                "lpips_backbone": logger.backbone, "mask_supervision": L.mask_supervision,
                "data": OmegaConf.to_container(cfg.data, resolve=True), "world_size": world,
                "device": device.type, "loss": OmegaConf.to_container(L, resolve=True),
                "freeze": list(T.freeze or ()), "batch_size": T.batch_size,
                "schedule_scale": T.schedule_scale, "threads": torch.get_num_threads()}
        info.update(init)  # the headers of the models it started from, read at the start
        weights = model.state_dict()
        if T.bn_recalibration:
            info["bn_recalibration"] = T.bn_recalibration
            weights = recalibrated_batchnorm(model, dataset, int(T.bn_recalibration),
                                             T.batch_size, device)
        export_model(run_dir / T.export, weights, model_config(cfg), info)
    logger.close()
    if world > 1:
        dist.barrier()
    return logs


def _progress(logs: dict[str, float]) -> dict[str, str]:
    out = {k: f"{logs[k]:.3f}" for k in ("recon", "mask") if k in logs}
    out["eff"] = f"{logs['diag/effective']:.1f}"
    if "diag/l1" in logs:
        out["l1"] = f"{logs['diag/l1']:.3f}/{logs['diag/l1_constant']:.3f}"
    return out


def _init_from(model, path, parts) -> dict:
    """Start a new run from ``trainer.init_from`` (a training checkpoint last.pt or an inference
    export) and then ``trainer.init_parts`` ({part: path}, e.g. ``{segmenter: runs/default_
    segmenter/model.safetensors}``: that model part only). Returns the header entries to record:
    ``init_from`` and ``init_parts`` (path, and the source's own header when it has one)."""
    from neuraltex.checkpoint import load_exported_model

    def load(p) -> tuple[dict, dict]:
        if str(p).endswith(".safetensors"):
            weights, _, info = load_exported_model(p)
            return weights, {"path": str(p), "info": info}
        return load_training_checkpoint(p)["modules"]["model"], {"path": str(p)}

    record: dict = {}
    if path:
        weights, record["init_from"] = load(path)
        model.load_state_dict(weights)
    for part, p in (parts or {}).items():
        weights, source = load(p)
        prefix = f"{part}."
        weights = {k[len(prefix):]: v for k, v in weights.items() if k.startswith(prefix)}
        if not weights or not hasattr(model, part):
            raise ValueError(f"trainer.init_parts: {p} has no model part {part!r}")
        getattr(model, part).load_state_dict(weights)
        record.setdefault("init_parts", {})[part] = source
    return record


def recalibrated_batchnorm(model, dataset, n_images: int, batch: int, device) -> dict:
    """Model weights whose BatchNorm running statistics are re-estimated (cumulative average,
    no gradient) on ``n_images`` whole training images, encoded and decoded as at inference.
    Training on crops (``data.crop``) leaves statistics of crop-sized maps, but the model is
    used at the full image size. The training model itself is left untouched."""
    import copy

    model = copy.deepcopy(model)
    norms = [m for m in model.modules() if isinstance(m, torch.nn.modules.batchnorm._BatchNorm)]
    model.eval()  # only the norms measure: spectral-norm vectors and the rest stay as trained
    for m in norms:
        m.reset_running_stats()
        m.momentum = None  # cumulative moving average over the calibration batches
        m.train()
    n = len(dataset)
    with torch.no_grad():
        for i in range(0, n_images, batch):
            items = [dataset[(n - 1 - j) % n] for j in range(i, min(i + batch, n_images))]
            x = torch.stack([it["image"] for it in items]).to(device)
            enc = model.encode(x, native=False)
            model.decode(enc.textons, tuple(x.shape[-2:]))
    return model.state_dict()


def _out_of_time(max_minutes, t0: float, world: int, device) -> bool:
    """``trainer.max_minutes`` reached (rank 0's clock decides for every rank)."""
    if not max_minutes:
        return False
    flag = torch.tensor([float(time.time() - t0 > 60 * max_minutes)], device=device)
    if world > 1:
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
