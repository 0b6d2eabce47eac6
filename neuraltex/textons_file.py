"""Texton files: ``.pt`` (tensors, loaded with ``weights_only=True``) and human-readable ``.json``.

Both hold the same content, format ``neuraltex.textons``, version 1::

    {"format": "neuraltex.textons", "version": 1,
     "coordinates": "normalized: short image side = 1, origin top-left, x right, y down",
     "canvas": [w, h], "dtype": "float32",
     "sets": [                                   # one entry per batch element
        {"textons": [{"p": .9, "delta": 1, "mu": [x, y], "cov": [[a, b], [b, d]],
                      "v": [vx, vy], "order": 0, "f": [...]}, ...]}]}

The ``.pt`` variant stores the batched tensors directly (keys ``mu cov v f p delta order``).
Everything read is validated (shapes, finite values, p and delta in [0, 1], symmetric
positive-definite covariances, unit directions); any problem raises :class:`TextonFileError`
with a one-line message. Writes are atomic. JSON floats are written with Python's shortest
round-trip repr, so a float32 set survives save -> load exactly.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import torch

from neuraltex.errors import InputError
from neuraltex.fileio import atomic_path, load_weights_only, write_text_atomic
from neuraltex.limits import MAX_FEATURES, MAX_SETS, MAX_TEXTONS
from neuraltex.textons import _TENSOR_FIELDS, Textons

FORMAT = "neuraltex.textons"
VERSION = 1
COORDINATES = "normalized: short image side = 1, origin top-left, x right, y down"
MAX_FILE_BYTES = 512 * 2**20
MIN_CANVAS, MAX_CANVAS = 1e-3, 1e3  # canvas sides in units of the short side (= 1 when written)
_DTYPES = {"float32": torch.float32, "float64": torch.float64, "float16": torch.float16,
           "bfloat16": torch.bfloat16}


class TextonFileError(InputError):
    """A texton file that is missing, corrupt, tampered with, or of an unknown version."""


def save_textons(textons: Textons, path: str | os.PathLike) -> None:
    """Write ``textons`` to ``path`` (.pt or .json, by suffix), atomically."""
    path = Path(path)
    textons = textons.detach().to("cpu")
    if path.suffix == ".json":
        write_text_atomic(path, json.dumps(_to_json(textons)))
    elif path.suffix == ".pt":
        payload = {"format": FORMAT, "version": VERSION, "coordinates": COORDINATES,
                   "canvas": list(textons.canvas)}
        payload.update({k: getattr(textons, k).contiguous() for k in _TENSOR_FIELDS})
        with atomic_path(path) as tmp:
            torch.save(payload, tmp)
    else:
        raise InputError(f"{path}: texton files end in .json or .pt")


def load_textons(path: str | os.PathLike) -> Textons:
    """Read and validate a texton file written by :func:`save_textons`."""
    path = Path(path)
    if not path.is_file():
        raise TextonFileError(f"{path}: no such file")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise TextonFileError(f"{path}: file is too large to be a texton file")
    if path.suffix == ".json":
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise TextonFileError(f"{path}: not valid JSON ({exc})") from None
        except RecursionError:
            raise TextonFileError(f"{path}: JSON nested too deeply") from None
        _check_header(data, path)
        textons = _from_json(data, path)
    elif path.suffix == ".pt":
        data = load_weights_only(path, TextonFileError, "texton file")
        _check_header(data, path)
        textons = _build(data, path)
    else:
        raise TextonFileError(f"{path}: texton files end in .json or .pt")
    _check_counts(textons, path)
    validate_textons(textons, path)
    return textons


def _check_counts(t: Textons, path: Path) -> None:
    """Texton sets, textons per set and feature channels within neuraltex.limits."""
    for n, cap, what in ((t.batch_size, MAX_SETS, "texton sets"),
                         (t.num_textons, MAX_TEXTONS, "textons per set"),
                         (t.feature_dim, MAX_FEATURES, "feature channels")):
        if n > cap:
            raise TextonFileError(f"{path}: {n} {what}, more than the limit of {cap}")


def validate_textons(t: Textons, source: str | os.PathLike = "textons") -> None:
    """Raise :class:`TextonFileError` unless every field holds a valid value."""
    for name in ("mu", "cov", "v", "f", "p", "delta"):
        if not torch.isfinite(getattr(t, name)).all():
            raise TextonFileError(f"{source}: '{name}' holds NaN or infinite values")
    for name in ("p", "delta"):
        x = getattr(t, name)
        if ((x < 0) | (x > 1)).any():
            raise TextonFileError(f"{source}: '{name}' must lie in [0, 1]")
    cov = t.cov.double()
    a, b, c, d = cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 0], cov[..., 1, 1]
    scale = cov.abs().amax(dim=(-1, -2)).clamp_min(1e-30)
    if ((b - c).abs() > 1e-5 * scale).any():
        raise TextonFileError(f"{source}: 'cov' must be symmetric")
    if ((a <= 0) | (a * d - b * c <= 0)).any():
        raise TextonFileError(f"{source}: 'cov' must be positive definite")
    norm = t.v.double().norm(dim=-1)
    tol = max(1e-3, 4 * torch.finfo(t.dtype).eps)  # bfloat16 directions are ~1% off unit
    if ((norm - 1).abs() > tol).any():
        raise TextonFileError(f"{source}: 'v' must hold unit vectors")
    if not all(MIN_CANVAS <= x <= MAX_CANVAS for x in t.canvas):  # NaN fails too
        raise TextonFileError(f"{source}: 'canvas' must be two numbers in "
                              f"[{MIN_CANVAS:g}, {MAX_CANVAS:g}]")


def _check_header(data, path: Path) -> None:
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise TextonFileError(f"{path}: not a {FORMAT} file")
    version = data.get("version")
    if version != VERSION:
        raise TextonFileError(f"{path}: unsupported {FORMAT} version {version!r} "
                              f"(this neuraltex reads version {VERSION})")


def _canvas(data: dict, path: Path) -> tuple[float, float]:
    canvas = data.get("canvas", [1.0, 1.0])
    if (not isinstance(canvas, (list, tuple)) or len(canvas) != 2
            or not all(isinstance(x, (int, float)) for x in canvas)):
        raise TextonFileError(f"{path}: 'canvas' must be [width, height]")
    return (float(canvas[0]), float(canvas[1]))


def _build(data: dict, path: Path) -> Textons:
    missing = [k for k in _TENSOR_FIELDS if not isinstance(data.get(k), torch.Tensor)]
    if missing:
        raise TextonFileError(f"{path}: missing or non-tensor fields {missing}")
    fields = {k: data[k] for k in _TENSOR_FIELDS}
    odd = [k for k, v in fields.items() if v.layout != torch.strided or v.device.type != "cpu"]
    if odd:
        raise TextonFileError(f"{path}: {odd} must be dense tensors (not sparse or meta)")
    if fields["order"].is_floating_point() or fields["order"].is_complex():
        raise TextonFileError(f"{path}: 'order' must hold integers")
    floats = [k for k in _TENSOR_FIELDS if k != "order"]
    if any(fields[k].dtype not in _DTYPES.values() for k in floats):
        raise TextonFileError(f"{path}: texton parameters must be floating point "
                              f"({', '.join(_DTYPES)})")
    dtypes = {fields[k].dtype for k in floats}
    dtype = dtypes.pop() if len(dtypes) == 1 else torch.float32  # mixed: one common dtype
    fields = {k: v.to(dtype) if k != "order" else v.long() for k, v in fields.items()}
    try:
        return Textons(**fields, canvas=_canvas(data, path))
    except (ValueError, TypeError) as exc:
        raise TextonFileError(f"{path}: {exc}") from None


def _to_json(t: Textons) -> dict:
    sets = []
    for b in range(t.batch_size):
        rows = []
        for k in range(t.num_textons):
            rows.append({
                "p": float(t.p[b, k]), "delta": float(t.delta[b, k]),
                "mu": t.mu[b, k].tolist(), "cov": t.cov[b, k].tolist(), "v": t.v[b, k].tolist(),
                "order": int(t.order[b, k]), "f": t.f[b, k].tolist(),
            })
        sets.append({"textons": rows})
    dtype = str(t.dtype).removeprefix("torch.")
    return {"format": FORMAT, "version": VERSION, "coordinates": COORDINATES,
            "canvas": list(t.canvas), "dtype": dtype, "sets": sets}


def _from_json(data: dict, path: Path) -> Textons:
    name = data.get("dtype", "float32")
    dtype = _DTYPES.get(name) if isinstance(name, str) else None
    sets = data.get("sets")
    if dtype is None:
        raise TextonFileError(f"{path}: unknown dtype {str(name)[:40]!r} ({', '.join(_DTYPES)})")
    if not isinstance(sets, list) or not sets:
        raise TextonFileError(f"{path}: 'sets' must be a non-empty list")
    if len(sets) > MAX_SETS:
        raise TextonFileError(f"{path}: {len(sets)} texton sets, more than the limit of "
                              f"{MAX_SETS}")
    cols: dict[str, list] = {k: [] for k in _TENSOR_FIELDS}
    for i, s in enumerate(sets):
        rows = s.get("textons") if isinstance(s, dict) else None
        if not isinstance(rows, list):
            raise TextonFileError(f"{path}: sets[{i}] has no 'textons' list")
        if len(rows) > MAX_TEXTONS:
            raise TextonFileError(f"{path}: sets[{i}] holds {len(rows)} textons, more than the "
                                  f"limit of {MAX_TEXTONS}")
        for k in _TENSOR_FIELDS:
            try:
                cols[k].append([row[k] for row in rows])
            except (KeyError, TypeError):
                raise TextonFileError(f"{path}: sets[{i}]: every texton needs '{k}'") from None
    try:
        fields = {k: torch.tensor(cols[k], dtype=dtype) for k in _TENSOR_FIELDS if k != "order"}
        if any(isinstance(o, bool) or not isinstance(o, int) for r in cols["order"] for o in r):
            raise TextonFileError(f"{path}: 'order' must hold integers")
        fields["order"] = torch.tensor(cols["order"], dtype=torch.int64)
        if fields["f"].dim() == 2:  # sets of zero textons
            fields["f"] = fields["f"].reshape(len(sets), 0, 0)
        return Textons(**fields, canvas=_canvas(data, path))
    except (ValueError, TypeError, IndexError, RuntimeError, OverflowError) as exc:
        raise TextonFileError(f"{path}: malformed texton values "
                              f"({' '.join(str(exc).split())[:200]})") from None
