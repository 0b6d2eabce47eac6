"""The fit prior: where ``neuraltex fit`` starts tuning the decoder G.

The shipped G was trained to decode textons of every procedural texture at once; ``fit``
instead tunes a copy of it to one texture, with a colour offset per texton
(:mod:`neuraltex.tuned_decoder`). A start made for *that* job — G's parameters meta-learned
with Reptile (Nichol et al. 2018) over many short fits of procedural textures
(:mod:`train.fit_prior`) — gets a texture's detail sooner than the shipped G or a random one
(the learned-initialization idea of Tancik et al. 2021 for coordinate networks).

The prior is a safetensors file beside the weights it was made from
(``default.safetensors`` -> ``default.fit_prior.safetensors``): G's parameters by name and a
header naming the base decoder's id. It only changes where the tuning starts: texture files
still store tuned minus *base* G, so files tuned from either start load the same way. A prior
made for other weights, or a damaged one, is not used (``load_model`` warns once).
"""

from __future__ import annotations

import copy
import json
import os
import warnings
from pathlib import Path

import torch
from torch import Tensor, nn

from neuraltex.checkpoint import read_safetensors, tensor_digest
from neuraltex.errors import InputError
from neuraltex.fileio import atomic_path

FORMAT = "neuraltex.fit_prior"
VERSION = 1
SUFFIX = ".fit_prior.safetensors"
MAX_BYTES = 256 * 2**20


class FitPriorError(InputError):
    """A fit prior that is unreadable, tampered with or made for other weights."""


def prior_path(weights: str | os.PathLike) -> Path:
    """The fit prior that belongs to a weights file: ``NAME.safetensors`` ->
    ``NAME.fit_prior.safetensors`` in the same folder."""
    weights = Path(weights)
    return weights.with_name(weights.name.removesuffix(".safetensors") + SUFFIX)


def decoder_id(model) -> str:
    """Short id of a model's decoder G (SHA-256 of its state dict): a prior belongs to the G
    it was meta-learned from (E_s and E_FC may differ, e.g. resampled queries)."""
    return tensor_digest(model.generator.state_dict())[:16]


def save_prior(path: str | os.PathLike, model, generator: dict[str, Tensor],
               info: dict) -> None:
    """Write G's parameters ``generator`` (by name) as the fit prior of ``model``, atomically;
    ``info`` (JSON-able: how it was made) goes into the header."""
    from safetensors.torch import save_file

    tensors = {k: v.detach().cpu().float().contiguous() for k, v in generator.items()}
    text = json.dumps({"format": FORMAT, "version": VERSION, "base_decoder": decoder_id(model),
                       "info": info}, sort_keys=True)
    with atomic_path(path) as tmp:
        save_file(tensors, str(tmp), metadata={"header": text,
                                                "sha256": tensor_digest(tensors, text.encode())})


def load_prior(path: str | os.PathLike, model) -> tuple[dict[str, Tensor], dict]:
    """(G's parameters by name, header) of the fit prior at ``path``, checked against
    ``model``; any problem is a :class:`FitPriorError` with a one-line message."""
    path = Path(path)
    if not path.is_file():
        raise FitPriorError(f"{path}: no such fit prior")
    if path.stat().st_size > MAX_BYTES:
        raise FitPriorError(f"{path}: larger than {MAX_BYTES >> 20} MB; not a fit prior")
    tensors, meta = read_safetensors(path, FitPriorError, "fit prior")
    text = meta.get("header", "")
    if meta.get("sha256") != tensor_digest(tensors, text.encode()):
        raise FitPriorError(f"{path}: content does not match its checksum")
    try:
        header = json.loads(text)
    except json.JSONDecodeError:
        raise FitPriorError(f"{path}: header is not JSON") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT \
            or header.get("version") != VERSION:
        raise FitPriorError(f"{path}: not a {FORMAT} file of version {VERSION}")
    if header.get("base_decoder") != decoder_id(model):
        raise FitPriorError(f"{path}: made for another decoder "
                            f"({header.get('base_decoder')!r}; this one is {decoder_id(model)})")
    base = dict(model.generator.named_parameters())
    if set(tensors) != set(base) or any(
            tensors[k].dtype != torch.float32 or tensors[k].shape != p.shape
            or not torch.isfinite(tensors[k]).all() for k, p in base.items()):
        raise FitPriorError(f"{path}: parameters do not match the model's decoder")
    return tensors, header


def attach_prior(model, weights: str | os.PathLike) -> None:
    """Give ``model`` (loaded from ``weights``) the fit prior beside them, if there is one:
    ``model.fit_prior`` = (parameters, header) or None. A prior that does not fit is skipped
    with one warning; the model then tunes from its own G."""
    model.fit_prior = None
    path = prior_path(weights)
    if not path.is_file():
        return
    try:
        model.fit_prior = load_prior(path, model)
    except FitPriorError as exc:
        warnings.warn(f"{exc}; fit starts from the model's own decoder", stacklevel=2)


def start_generator(model, use_prior: bool = True) -> nn.Module:
    """A copy of G to tune: with the model's fit prior when it has one (and ``use_prior``),
    else the model's own G."""
    G = copy.deepcopy(model.generator)
    prior = getattr(model, "fit_prior", None) if use_prior else None
    if prior is not None:
        with torch.no_grad():
            for name, p in G.named_parameters():
                p.copy_(prior[0][name])
    return G

