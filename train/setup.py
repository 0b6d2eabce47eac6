"""Build what a run trains, and restore it: from the run's own checkpoint (resume) or from
other models (``trainer.init_from``, ``trainer.init_parts``)."""

from __future__ import annotations

import logging
import os
import shutil
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import torch
from omegaconf import DictConfig, OmegaConf
from torch.nn.parallel import DistributedDataParallel as DDP

from neuraltex.checkpoint import load_exported_model, load_training_checkpoint, set_rng_state
from neuraltex.errors import InputError
from neuraltex.heap import keep_freed_memory
from neuraltex.model import TextonAutoencoder, build_model
from neuraltex.model_config import ModelConfig
from neuraltex.nn_utils import adam, flush_subnormals, load_adam_state
from train.loss_config import LossConfig
from train.objective import CriticObjective, GeneratorObjective
from train.sync_batchnorm import cross_rank_batchnorm


@dataclass
class Parts:
    """The model, its critics, their objectives and optimizers: what a step changes."""

    model: TextonAutoencoder
    critics: CriticObjective
    gen: GeneratorObjective
    gen_step: torch.nn.Module  # gen, or its DDP wrapper
    crit_step: torch.nn.Module  # critics, or their DDP wrapper
    opt_g: torch.optim.Optimizer
    opt_d: torch.optim.Optimizer
    loss: LossConfig
    device: torch.device
    amp: bool = False  # bfloat16 autocast (CUDA, or a CPU with bf16 instructions)


@dataclass
class Progress:
    """Where a run starts: step, wall time spent before, and the headers it started from."""

    start: int = 0
    wall_before: float = 0.0
    init: dict = field(default_factory=dict)


def model_config(cfg: DictConfig) -> ModelConfig:
    return ModelConfig.from_dict(OmegaConf.to_container(cfg.model, resolve=True))


def loss_config(cfg: DictConfig) -> LossConfig:
    return LossConfig.from_dict(OmegaConf.to_container(cfg.loss, resolve=True))


def build(cfg: DictConfig, device: torch.device, world: int = 1) -> Parts:
    """Model, critics, objectives and Adam optimizers as configured (``trainer.freeze`` parts
    get no gradient); DDP-wrapped step modules when ``world`` > 1."""
    T, mcfg, loss = cfg.trainer, model_config(cfg), loss_config(cfg)
    flush_subnormals(device)
    if device.type == "cpu":
        keep_freed_memory()  # large tensors reused, not page-faulted in again (neuraltex.heap)
    model, image_critic, patch_critic = build_model(mcfg, with_critics=True)
    if world > 1 and T.get("sync_batchnorm"):  # statistics over the global batch
        sync_batchnorm(model, device)
    critics = CriticObjective(image_critic, patch_critic, loss, mcfg.image_size).to(device)
    gen = GeneratorObjective(model, critics, loss).to(device)
    if T.get("channels_last"):  # NHWC convolutions: SPADE G ~1.26x less CPU (oneDNN)
        gen.to(memory_format=torch.channels_last)  # the model and LPIPS
        critics.to(memory_format=torch.channels_last)
    for name in T.freeze or ():  # e.g. [segmenter]: fine-tune the rest around a fixed E_s
        model_part(model, name, "trainer.freeze").requires_grad_(False)
    compiled = [model_part(model, name, "trainer.compile") for name in T.get("compile") or ()]
    if compiled and device.type == "cpu" and not cxx_compiler():
        warnings.warn("trainer.compile: no C++ compiler (g++, clang++; $CXX) for torch.compile "
                      "on the CPU; the model runs uncompiled", stacklevel=2)
        compiled = []
    for part in compiled:  # e.g. E_s: inductor's fused kernels, in place (same state_dict)
        part.compile()
    if compiled:  # the constants E_s caches with lru_cache are traced: pure functions;
        warnings.filterwarnings("ignore", message="Dynamo detected a call to a `functools")
        logging.getLogger("torch.utils.cpp_extension").setLevel(logging.ERROR)  # "no CUDA"
    trainable = [p for p in model.parameters() if p.requires_grad]
    opt_g = adam(trainable, lr=T.lr, betas=tuple(T.betas))
    opt_d = adam(critics.parameters(), lr=T.d_lr, betas=tuple(T.betas))
    wrap = _ddp if world > 1 else (lambda m: m)
    return Parts(model, critics, gen, wrap(gen), wrap(critics), opt_g, opt_d, loss, device,
                 amp=use_amp(T.amp, device))


PARTS = ("encoder", "segmenter", "generator")  # what trainer.freeze / compile may name


def cxx_compiler() -> str | None:
    """The C++ compiler inductor would build CPU kernels with ($CXX, else g++, clang++ or
    c++ on PATH), or None."""
    names = [os.environ["CXX"]] if os.environ.get("CXX") else ["g++", "clang++", "c++"]
    return next((path for name in names if (path := shutil.which(name))), None)


def check_part(name: str, key: str) -> None:
    """InputError unless ``name``, from the config list ``key``, is a model part."""
    if name not in PARTS:
        raise InputError(f"{key}: unknown model part {name!r} (one of {', '.join(PARTS)})")


def model_part(model: TextonAutoencoder, name: str, key: str) -> torch.nn.Module:
    """The model part ``name`` (E_FC, E_s or G) of a config list ``key``."""
    check_part(name, key)
    return getattr(model, name)


def use_amp(setting, device: torch.device) -> bool:
    """``trainer.amp``: true / false, or "auto": bfloat16 autocast on CUDA and on a CPU with
    native bfloat16 instructions (AVX512-BF16 / AMX, where oneDNN runs it fast; elsewhere it
    is emulated and slower than float32)."""
    if setting != "auto":
        return bool(setting)
    if device.type == "cuda":
        return True
    return device.type == "cpu" and bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())


def sync_batchnorm(model: torch.nn.Module, device: torch.device) -> None:
    """E_FC's and G's BatchNorm over every rank's images (``trainer.sync_batchnorm``):
    torch's SyncBatchNorm on GPUs, train.sync_batchnorm's on the CPU, where torch's refuses."""
    if device.type == "cpu":
        cross_rank_batchnorm(model)
    else:
        torch.nn.SyncBatchNorm.convert_sync_batchnorm(model)  # in place below the top module


def _ddp(module: torch.nn.Module) -> DDP:
    """DDP that tolerates parameters a step leaves unused (the critics in the segmenter
    warm-up, the GAN heads when a term is off). torch's note that a step used them all after
    all is expected here: filtered where it comes as a Python warning; the reducer's C++ copy,
    from the autograd thread, still prints once per rank at the first backward."""
    import warnings

    warnings.filterwarnings("ignore", message=".*find_unused_parameters=True.*")
    return DDP(module, find_unused_parameters=True)


def resume_file(T: DictConfig, run_dir: Path) -> Path | None:
    """The checkpoint the run resumes from: ``trainer.resume``, or with "auto"
    ``run_dir/last.pt``; None when there is none to resume from."""
    path = run_dir / "last.pt" if T.resume == "auto" else T.resume
    return Path(path) if path and Path(path).exists() else None


def check_inputs(T: DictConfig, run_dir: Path) -> None:
    """InputError naming the missing file, and the stage that makes it, when a file the run
    starts from (``trainer.init_from``, ``trainer.init_parts``, ``trainer.resume``) is absent,
    or naming a ``trainer.freeze`` / ``trainer.compile`` entry that is no model part, before
    anything is built. A run that resumes from its own ``run_dir/last.pt``
    (``trainer.resume=auto``) needs none of the files it started from."""
    paths = [("trainer.init_from", T.init_from), *((f"trainer.init_parts.{k}", v)
                                                    for k, v in (T.init_parts or {}).items())]
    if T.resume == "auto" and resume_file(T, run_dir):
        paths = []
    for key in ("freeze", "compile"):
        for name in T.get(key) or ():
            check_part(name, f"trainer.{key}")
    if T.resume and T.resume != "auto":
        paths.append(("trainer.resume", T.resume))
    for key, path in paths:
        if path and not Path(path).is_file():
            stage = Path(path).parent.name
            known = (Path(__file__).parent / "configs" / "experiment" / f"{stage}.yaml").exists()
            hint = f"; train that stage first: python -m train experiment={stage}" if known else ""
            raise InputError(f"{key}: {path} does not exist{hint}")


def restore(parts: Parts, T: DictConfig, run_dir: Path) -> Progress:
    """Resume from ``trainer.resume`` (a last.pt, or "auto": run_dir/last.pt when it exists),
    else start from ``trainer.init_from`` / ``trainer.init_parts``, else from scratch."""
    resume = resume_file(T, run_dir)
    if resume:
        ck = load_training_checkpoint(resume)
        parts.model.load_state_dict(ck["modules"]["model"])
        parts.critics.load_state_dict(ck["modules"]["critics"])
        load_adam_state(parts.opt_g, ck["optimizers"]["g"])
        load_adam_state(parts.opt_d, ck["optimizers"]["d"])
        set_rng_state(ck["rng"])
        extra = ck.get("extra", {})
        return Progress(ck["step"], float(extra.get("wall_s", 0.0)), extra.get("init", {}))
    if T.init_from or T.init_parts:
        return Progress(init=init_from(parts.model, T.init_from, T.init_parts))
    return Progress()


def init_from(model: TextonAutoencoder, path, parts) -> dict:
    """Start a new run from ``trainer.init_from`` (a training checkpoint last.pt or an inference
    export) and then ``trainer.init_parts`` ({part: path}, e.g. ``{segmenter: runs/default_
    segmenter/model.safetensors}``: that model part only). Returns the header entries to record:
    ``init_from`` and ``init_parts`` (path, and the source's own header when it has one)."""

    def load(p) -> tuple[dict, dict]:
        if str(p).endswith(".safetensors"):
            weights, _, info = load_exported_model(p)
            return weights, {"path": str(p), "info": info}
        return load_training_checkpoint(p)["modules"]["model"], {"path": str(p)}

    record: dict = {}
    if path:
        weights, record["init_from"] = load(path)
        model.load_state_dict(_fit_queries(weights, model))
    for part, p in (parts or {}).items():
        weights, source = load(p)
        prefix = f"{part}."
        weights = {k[len(prefix):]: v for k, v in _fit_queries(weights, model).items()
                   if k.startswith(prefix)}
        if not weights or not hasattr(model, part):
            raise ValueError(f"trainer.init_parts: {p} has no model part {part!r}")
        getattr(model, part).load_state_dict(weights)
        record.setdefault("init_parts", {})[part] = source
    return record


def _fit_queries(weights: dict, model: TextonAutoencoder) -> dict:
    """Weights whose E_s has another number of queries than ``model`` (e.g. the shipped 100
    for a dense-texture run with ``model.num_queries=196``): queries resampled to the model's
    anchor grid (:mod:`neuraltex.query_grid`); other weights as they are."""
    from neuraltex.query_grid import adapt_queries

    n = getattr(model.segmenter, "num_queries", None)
    theirs = weights.get("segmenter.query_feat")
    if n is None or theirs is None or theirs.shape[0] == n:
        return weights
    return adapt_queries(weights, n)
