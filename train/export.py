"""The end of a run: the inference export (weights + a header saying how they were trained),
with BatchNorm statistics optionally re-estimated at the full image size first."""

from __future__ import annotations

import copy
from pathlib import Path

import torch
from omegaconf import DictConfig, OmegaConf

from neuraltex.checkpoint import export_model
from train.setup import Parts, Progress


def export(parts: Parts, cfg: DictConfig, dataset, steps: int, wall_s: float, world: int,
           lpips_backbone: str, progress: Progress) -> Path:
    """Write ``run_dir/trainer.export``; returns its path."""
    T = cfg.trainer
    info = {"steps": steps, "wall_s": round(wall_s, 1), "lpips_backbone": lpips_backbone,
            "mask_supervision": parts.loss.mask_supervision,
            "data": OmegaConf.to_container(cfg.data, resolve=True), "world_size": world,
            "device": parts.device.type, "loss": OmegaConf.to_container(cfg.loss, resolve=True),
            "freeze": list(T.freeze or ()), "batch_size": T.batch_size,
            "schedule_scale": T.schedule_scale, "threads": torch.get_num_threads()}
    info.update(progress.init)  # the headers of the models it started from, read at the start
    weights = parts.model.state_dict()
    if T.bn_recalibration:
        info["bn_recalibration"] = T.bn_recalibration
        weights = recalibrated_batchnorm(parts.model, dataset, int(T.bn_recalibration),
                                         T.batch_size, parts.device)
    path = Path(cfg.run_dir) / T.export
    export_model(path, weights, parts.model.config, info)
    return path


def recalibrated_batchnorm(model, dataset, n_images: int, batch: int, device) -> dict:
    """Model weights whose BatchNorm running statistics are re-estimated (cumulative average,
    no gradient) on ``n_images`` whole training images, encoded and decoded as at inference.
    Training on crops (``data.crop``) leaves statistics of crop-sized maps, but the model is
    used at the full image size. The training model itself is left untouched."""
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
