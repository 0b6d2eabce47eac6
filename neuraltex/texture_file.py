"""Texture files (``.ntex``): one tuned texture — its textons, its segments and the change of
the decoder G that :mod:`neuraltex.fit` made — tied to the base model it was tuned from.

The file is safetensors (read without unpickling anything) with a JSON header:

    format "neuraltex.texture", version 3 (1, 2 still read), base_model (id of the base weights),
    source {file, width, height, sha256 of the file's bytes}, size [H, W] it was fitted at,
    segmenter, fit {steps, seconds, psnr, base_psnr, plain_psnr, detail}, canvas [w, h],
    sha256 (of all of it)

and tensors ``textons.{mu, cov, v, f, order}`` (1, K, ...), ``labels`` (H, W) int32 and
``generator.<name>``: tuned minus base parameters of G in float16 (a few hundred KB for the
tiny preset), from version 2 ``textons.detail`` (1, K, 3, S, S) float16, the textons'
detail sprites (:mod:`neuraltex.texton_detail`; K = 400, S = 16: 600 KB), and from version 3
``elements`` (K,) int32, the element each texton belongs to (:mod:`neuraltex.texton_elements`).
A file whose
content does not match its checksum, or that was tuned from other
base weights, is refused with one line.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from neuraltex.checkpoint import read_safetensors, tensor_digest
from neuraltex.errors import InputError
from neuraltex.fileio import atomic_path
from neuraltex.texton_detail import attach, split
from neuraltex.textons import Textons

FORMAT = "neuraltex.texture"
VERSION = 3
READS = (1, 2, 3)  # versions this module reads (1: no detail sprites, < 3: no elements)
SUFFIX = ".ntex"
MAX_FILE_BYTES = 64 * 2**20
MAX_TEXTONS = 4096
MAX_SIDE = 4096
MAX_SPRITE = 64
_TEXTON_FIELDS = ("mu", "cov", "v", "f", "order")


class TextureFileError(InputError):
    """A texture file that is missing, corrupt, tampered with or made for other weights."""


@dataclass
class Texture:
    textons: Textons               # (1, K), f = [f_a, d, vec(D)] (neuraltex.tuned_decoder)
    labels: np.ndarray             # (H, W) int64 segment (texton index) of each pixel
    generator: dict[str, Tensor]   # tuned parameters of G, by name (float32)
    header: dict                   # base_model, source, size, segmenter, fit
    elements: np.ndarray | None = None  # (K,) int64 element of each texton (version >= 3)


def model_id(model) -> str:
    """Short id of a model's weights (SHA-256 of its state dict)."""
    return tensor_digest(model.state_dict())[:16]


def save_texture(path: str | os.PathLike, model, textons: Textons, labels: np.ndarray,
                 generator: dict[str, Tensor], header: dict,
                 elements: np.ndarray | None = None) -> int:
    """Write a texture file atomically; returns its size in bytes. ``header`` holds source,
    size, segmenter and fit; format, version, base model and checksum are added here;
    ``elements`` (K,): the element of each texton (:mod:`neuraltex.texton_elements`)."""
    from safetensors.torch import save_file

    from neuraltex.tuned_decoder import COLOUR

    base = dict(model.generator.named_parameters())
    plain, sprites = split(textons, model.generator.feature_channels - 2 + COLOUR)
    tensors = {f"textons.{k}": getattr(plain, k).detach().cpu().contiguous()
               for k in _TEXTON_FIELDS}
    if sprites is not None:
        tensors["textons.detail"] = sprites.detach().cpu().half().contiguous()
    tensors["labels"] = torch.from_numpy(np.ascontiguousarray(labels, dtype=np.int32))
    if elements is not None:
        tensors["elements"] = torch.from_numpy(np.ascontiguousarray(elements, dtype=np.int32))
    for name, p in generator.items():
        tensors[f"generator.{name}"] = (p.detach().cpu() - base[name].detach().cpu()).half()
    meta = {**header, "format": FORMAT, "version": VERSION, "base_model": model_id(model),
            "canvas": list(textons.canvas)}
    text = json.dumps(meta, sort_keys=True)
    with atomic_path(path) as tmp:
        save_file(tensors, str(tmp), metadata={"header": text,
                                                "sha256": _digest(tensors, text)})
    return Path(path).stat().st_size


def load_texture(path: str | os.PathLike, model) -> Texture:
    """Read and validate a texture file against the base ``model`` it must have been tuned
    from; any problem is a :class:`TextureFileError` with a one-line message."""
    path = Path(path)
    tensors, text = _read(path)
    try:
        header = json.loads(text)
    except json.JSONDecodeError:
        raise TextureFileError(f"{path}: texture header is not JSON") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        raise TextureFileError(f"{path}: not a {FORMAT} file")
    if header.get("version") not in READS:
        raise TextureFileError(f"{path}: unsupported texture file version "
                               f"{header.get('version')!r} (this neuraltex reads {READS})")
    if header.get("base_model") != (mine := model_id(model)):
        raise TextureFileError(f"{path}: tuned from other base weights "
                               f"({header.get('base_model')!r}; this model is {mine}); "
                               "fit it again or pass the --checkpoint it was made with")
    textons = _textons(tensors, header, path, model)
    K = textons.num_textons
    return Texture(textons, _labels(tensors, K, path), _generator(tensors, model, path), header,
                   _elements(tensors, K, path))


def _read(path: Path) -> tuple[dict[str, Tensor], str]:
    if not path.is_file():
        raise TextureFileError(f"{path}: no such texture file")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise TextureFileError(f"{path}: larger than {MAX_FILE_BYTES >> 20} MB; not a texture "
                               "file")
    tensors, meta = read_safetensors(path, TextureFileError, "texture file")
    text = meta.get("header", "")
    if meta.get("sha256") != _digest(tensors, text):
        raise TextureFileError(f"{path}: content does not match its checksum (file modified "
                               "or corrupted)")
    return tensors, text


def _textons(tensors: dict, header: dict, path: Path, model) -> Textons:
    from neuraltex.textons_file import validate_textons
    from neuraltex.tuned_decoder import COLOUR

    fields = {k: tensors.get(f"textons.{k}") for k in _TEXTON_FIELDS}
    if any(v is None for v in fields.values()):
        raise TextureFileError(f"{path}: texton tensors are missing")
    if fields["order"].dtype != torch.int64 or any(
            fields[k].dtype != torch.float32 for k in _TEXTON_FIELDS if k != "order"):
        raise TextureFileError(f"{path}: texton tensors have the wrong dtypes")
    K = fields["mu"].shape[1] if fields["mu"].dim() == 3 else -1
    want = model.generator.feature_channels - 2 + COLOUR
    if not 0 < K <= MAX_TEXTONS or fields["f"].shape != (1, K, want):
        raise TextureFileError(f"{path}: expected 1 set of 1..{MAX_TEXTONS} textons with "
                               f"{want} feature channels")
    canvas = header.get("canvas")
    if (not isinstance(canvas, list) or len(canvas) != 2
            or not all(isinstance(c, (int, float)) and 0 < c < 1e6 for c in canvas)):
        raise TextureFileError(f"{path}: 'canvas' must be two positive numbers")
    ones = torch.ones(1, K)
    try:
        t = Textons(**fields, p=ones, delta=ones, canvas=tuple(canvas))
    except (ValueError, TypeError) as exc:
        raise TextureFileError(f"{path}: {exc}") from None
    validate_textons(t, path)
    return t if "textons.detail" not in tensors else attach(t, _detail(tensors, K, path))


def _detail(tensors: dict, K: int, path: Path) -> Tensor:
    """The texton sprites (1, K, 3, S, S) float16 -> float32, validated."""
    d = tensors["textons.detail"]
    if (d.dtype != torch.float16 or d.dim() != 5 or tuple(d.shape[:3]) != (1, K, 3)
            or d.shape[3] != d.shape[4] or not 2 <= d.shape[3] <= MAX_SPRITE
            or not torch.isfinite(d).all() or d.abs().max() > 4):
        raise TextureFileError(f"{path}: 'textons.detail' must be (1, K, 3, S, S) float16 "
                               f"sprites, 2 <= S <= {MAX_SPRITE}, values in [-4, 4]")
    return d.float()


def _labels(tensors: dict, K: int, path: Path) -> np.ndarray:
    labels = tensors.get("labels")
    if (labels is None or labels.dtype != torch.int32 or labels.dim() != 2
            or not 0 < max(labels.shape) <= MAX_SIDE or labels.min() < 0 or labels.max() >= K):
        raise TextureFileError(f"{path}: 'labels' must be an (H, W) int32 map of texton indices")
    return labels.numpy().astype(np.int64)


def _elements(tensors: dict, K: int, path: Path) -> np.ndarray | None:
    e = tensors.get("elements")
    if e is None:
        return None
    if e.dtype != torch.int32 or tuple(e.shape) != (K,) or e.min() < 0 or e.max() >= K:
        raise TextureFileError(f"{path}: 'elements' must be a (K,) int32 vector of element "
                               "ids in [0, K)")
    return e.numpy().astype(np.int64)


def _generator(tensors: dict, model, path: Path) -> dict[str, Tensor]:
    base = dict(model.generator.named_parameters())
    delta = {k[len("generator."):]: v for k, v in tensors.items() if k.startswith("generator.")}
    if set(delta) != set(base):
        raise TextureFileError(f"{path}: decoder parameters do not match the base model's")
    out = {}
    for name, p in base.items():
        d = delta[name]
        if d.dtype != torch.float16 or d.shape != p.shape or not torch.isfinite(d).all():
            raise TextureFileError(f"{path}: decoder parameter {name} is malformed")
        out[name] = p.detach().cpu() + d.float()
    return out


def _digest(tensors: dict[str, Tensor], text: str) -> str:
    return tensor_digest(tensors, text.encode())
