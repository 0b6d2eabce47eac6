"""Self-describing checkpoints, written atomically and read without unpickling code.

Two kinds:

- **training checkpoints** (``.pt``): resolved config, model + discriminator weights, optimizer
  and scheduler states, step, and every RNG state needed so a resumed run continues exactly.
  Read with ``torch.load(weights_only=True)``: only tensors and plain containers come back.
- **inference exports** (``.safetensors``): model weights plus a JSON header (format, version,
  model config, training summary) and a SHA-256 of the tensor contents, so a file whose weights
  were altered after export is rejected.

Every problem with a file raises :class:`CheckpointError` (an :class:`InputError`) whose
message fits on one line.
"""

from __future__ import annotations

import hashlib
import json
import os
import random
from pathlib import Path
from typing import Any

import numpy as np
import torch

from neuraltex.errors import InputError
from neuraltex.fileio import atomic_path, load_weights_only
from neuraltex.model_config import ModelConfig

TRAIN_FORMAT = "neuraltex.train-checkpoint"
EXPORT_FORMAT = "neuraltex.model"
VERSION = 1
MAX_HEADER_DEPTH = 64  # nesting of a header's 'info' (each training stage adds a few levels)


class CheckpointError(InputError):
    """A checkpoint or model file that is missing, corrupt, tampered with or incompatible."""


# ------------------------------------------------------------------------- RNG state
def rng_state() -> dict[str, Any]:
    """Python, NumPy and torch RNG states as weights-only-loadable values."""
    np_state = np.random.get_state()
    state = {
        "python": [list(x) if isinstance(x, tuple) else x for x in random.getstate()],
        "numpy": {"key": torch.from_numpy(np_state[1].astype(np.int64)), "pos": int(np_state[2]),
                  "has_gauss": int(np_state[3]), "cached": float(np_state[4])},
        "torch": torch.get_rng_state(),
    }
    if torch.cuda.is_available():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def set_rng_state(state: dict[str, Any]) -> None:
    py = state["python"]
    random.setstate((py[0], tuple(py[1]), py[2]))
    n = state["numpy"]
    np.random.set_state(("MT19937", n["key"].numpy().astype(np.uint32), n["pos"],
                         n["has_gauss"], n["cached"]))
    torch.set_rng_state(state["torch"])
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(state["cuda"])


# ----------------------------------------------------------------- training checkpoints
def save_training_checkpoint(path: str | os.PathLike, *, step: int, config: dict,
                             modules: dict[str, dict], optimizers: dict[str, dict],
                             extra: dict | None = None) -> None:
    """Write a resumable checkpoint atomically. ``modules``/``optimizers``: name -> state_dict."""
    payload = {"format": TRAIN_FORMAT, "version": VERSION, "step": int(step),
               "config": config, "modules": modules, "optimizers": optimizers,
               "rng": rng_state(), "extra": extra or {}}
    with atomic_path(path) as tmp:
        torch.save(payload, tmp)


def load_training_checkpoint(path: str | os.PathLike) -> dict:
    data = _torch_load(path)
    if not isinstance(data, dict) or data.get("format") != TRAIN_FORMAT:
        raise CheckpointError(f"{path}: not a neuraltex training checkpoint")
    _check_version(data.get("version"), path)
    for key in ("step", "config", "modules", "optimizers", "rng"):
        if key not in data:
            raise CheckpointError(f"{path}: checkpoint lacks '{key}'")
    return data


# ------------------------------------------------------------------- inference exports
def export_model(path: str | os.PathLike, state_dict: dict[str, torch.Tensor],
                 model_config: ModelConfig, info: dict | None = None) -> None:
    """Write inference weights as safetensors with a self-describing, hashed header."""
    from safetensors.torch import save_file

    tensors = {k: v.detach().cpu().contiguous() for k, v in state_dict.items()}
    meta = {"format": EXPORT_FORMAT, "version": str(VERSION),
            "model_config": json.dumps(model_config.to_dict(), sort_keys=True),
            "info": json.dumps(info or {}, sort_keys=True),
            "sha256": tensor_digest(tensors)}
    with atomic_path(path) as tmp:
        save_file(tensors, str(tmp), metadata=meta)


def load_exported_model(path: str | os.PathLike) -> tuple[dict[str, torch.Tensor], dict, dict]:
    """Read an export; returns (state_dict, model_config, info). Verifies the content hash."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no such model file")
    tensors, meta = read_safetensors(path, CheckpointError, "safetensors model")
    if meta.get("format") != EXPORT_FORMAT:
        raise CheckpointError(f"{path}: not a neuraltex model export")
    _check_version(int(meta["version"]) if meta.get("version", "").isdigit() else None, path)
    if meta.get("sha256") != tensor_digest(tensors):
        raise CheckpointError(f"{path}: weights do not match their recorded checksum "
                              "(file modified or corrupted)")
    return (tensors, *_header(meta, path))


def read_safetensors(path: Path, error: type[Exception],
                     what: str) -> tuple[dict[str, torch.Tensor], dict[str, str]]:
    """(tensors, metadata) of a safetensors file; a file it cannot read raises ``error`` with
    a one-line message naming ``what`` it should have been."""
    from safetensors import SafetensorError, safe_open

    try:
        with safe_open(str(path), framework="pt") as fh:
            meta = fh.metadata() or {}
            return {k: fh.get_tensor(k) for k in fh.keys()}, meta
    except (SafetensorError, OSError, ValueError, RuntimeError) as exc:
        raise error(f"{path}: not a readable {what} "
                    f"({' '.join(str(exc).split())[:160]})") from None


def export_header(path: str | os.PathLike) -> tuple[dict, dict]:
    """(model_config, info) of an export, read from its header only (no weights, no hash
    check: for ``--version``; :func:`load_exported_model` validates)."""
    from safetensors import SafetensorError, safe_open

    try:
        with safe_open(str(path), framework="pt") as fh:
            meta = fh.metadata() or {}
    except (SafetensorError, OSError, ValueError, RuntimeError):
        raise CheckpointError(f"{path}: not a readable neuraltex model export") from None
    return _header(meta, path)


def _header(meta: dict[str, str], path: str | os.PathLike) -> tuple[dict, dict]:
    """(model_config, info) of an export header: JSON objects of bounded depth, the config
    valid for :class:`ModelConfig`; anything else is a :class:`CheckpointError`."""
    try:
        config, info = json.loads(meta["model_config"]), json.loads(meta.get("info", "{}"))
    except (KeyError, json.JSONDecodeError, RecursionError):
        raise CheckpointError(f"{path}: model header is malformed") from None
    if not isinstance(config, dict) or not isinstance(info, dict):
        raise CheckpointError(f"{path}: model header 'model_config' and 'info' must be objects")
    if _depth(info) > MAX_HEADER_DEPTH:
        raise CheckpointError(f"{path}: model header 'info' nests deeper than {MAX_HEADER_DEPTH}")
    try:
        ModelConfig.from_dict(config)
    except (ValueError, TypeError) as exc:
        raise CheckpointError(f"{path}: model header: {exc}") from None
    return config, info


def _depth(x: Any) -> int:
    children = x.values() if isinstance(x, dict) else x if isinstance(x, list) else ()
    return 1 + max(map(_depth, children), default=0)


def summary(config: dict, info: dict) -> str:
    """One line: architecture and how it was trained (stages, steps, wall time, supervision)."""
    queries = config.get("num_queries") or "preset"
    stages, cur = [], info
    while isinstance(cur, dict) and cur and len(stages) < MAX_HEADER_DEPTH:
        sup = cur.get("mask_supervision", "?")
        freeze = cur.get("freeze") if isinstance(cur.get("freeze"), list) else None
        frozen = f", {'+'.join(map(str, freeze))} frozen" if freeze else ""
        parts = "".join(f", {part} taken from a {_sub(src, 'info').get('steps', '?')}-step "
                        "model" for part, src in _sub(cur, "init_parts").items())
        wall = cur.get("wall_s", 0)
        minutes = f"{wall / 60:.0f}" if isinstance(wall, (int, float)) else "?"
        stages.insert(0, f"{cur.get('steps', '?')} steps / {minutes} min "
                         f"on {cur.get('device', '?')} (mask supervision {sup}{frozen}{parts})")
        cur = _sub(_sub(cur, "init_from"), "info")
    return (f"preset {config.get('preset')}, {queries} queries, trained at "
            f"{config.get('image_size')} px: " + " then ".join(stages)
            + f"; LPIPS backbone {info.get('lpips_backbone', '?')}")


def _sub(d: Any, key: str) -> dict:
    """``d[key]`` when both are dicts, else {}: headers from other tools may hold anything."""
    value = d.get(key) if isinstance(d, dict) else None
    return value if isinstance(value, dict) else {}


def tensor_digest(tensors: dict[str, torch.Tensor], prefix: bytes = b"") -> str:
    """SHA-256 (hex) of named tensors (names, dtypes, shapes, bytes), after ``prefix``."""
    h = hashlib.sha256(prefix)
    for name in sorted(tensors):
        t = tensors[name].detach().cpu().contiguous()
        h.update(f"{name}|{t.dtype}|{tuple(t.shape)}|".encode())
        h.update(t.reshape(-1).view(torch.uint8).numpy().tobytes() if t.numel() else b"")
    return h.hexdigest()


def _torch_load(path: str | os.PathLike) -> Any:
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no such checkpoint")
    return load_weights_only(path, CheckpointError, "checkpoint")


def _check_version(version: Any, path: str | os.PathLike) -> None:
    if version != VERSION:
        raise CheckpointError(f"{path}: unsupported checkpoint version {version!r} "
                              f"(this neuraltex reads version {VERSION})")
