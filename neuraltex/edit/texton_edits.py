"""Texton-centric edits (seed 003, 4.4.5.1): select textons, then move / scale / rotate /
delete / duplicate them. Works on one texton set (batch size 1), the way a user edits.

Selections return a (K,) bool mask. Transforms act about each texton's own centre. A JSON edit
list applies several edits in order::

    [{"select": {"point": [0.3, 0.4]}, "op": "move", "by": [0.05, 0]},
     {"select": {"similar_to": 7, "threshold": 0.9}, "op": "scale", "by": 1.5},
     {"select": {"region": [0, 0, 0.5, 1]}, "op": "rotate", "degrees": 30},
     {"select": {"index": [1, 2]}, "op": "delete"},
     {"select": {"index": [3]}, "op": "duplicate", "offset": [0.1, 0.1]}]
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import torch
from torch import Tensor

from neuraltex.errors import InputError
from neuraltex.limits import MAX_EDITS, MAX_TEXTONS, check_count
from neuraltex.splatting import precision
from neuraltex.textons import Textons

MAX_EDIT_FILE_BYTES = 2**20


def _one(t: Textons) -> None:
    if t.batch_size != 1:
        raise ValueError("texton edits work on a single texton set (batch size 1)")


def select_point(t: Textons, x: float, y: float) -> Tensor:
    """The effective texton whose Gaussian is nearest to (x, y) in Mahalanobis distance."""
    _one(t)
    d = torch.tensor([x, y], dtype=t.dtype) - t.mu[0]
    P = precision(t.cov[0])
    m2 = P[:, 0] * d[:, 0] ** 2 + 2 * P[:, 1] * d[:, 0] * d[:, 1] + P[:, 2] * d[:, 1] ** 2
    m2 = torch.where(t.delta[0] > 0.5, m2, torch.full_like(m2, math.inf))
    mask = torch.zeros(t.num_textons, dtype=torch.bool)
    if torch.isfinite(m2).any():
        mask[int(m2.argmin())] = True
    return mask


def select_index(t: Textons, indices) -> Tensor:
    _one(t)
    mask = torch.zeros(t.num_textons, dtype=torch.bool)
    idx = torch.as_tensor(indices, dtype=torch.long).reshape(-1)
    if idx.numel() and (idx.min() < 0 or idx.max() >= t.num_textons):
        raise IndexError(f"texton index out of range [0, {t.num_textons})")
    mask[idx] = True
    return mask


def select_region(t: Textons, box) -> Tensor:
    _one(t)
    return t.in_region(tuple(box))[0] & (t.delta[0] > 0.5)


def select_similar(t: Textons, index: int, threshold: float = 0.9,
                   channels: int | None = None) -> Tensor:
    """Effective textons whose feature has cosine similarity >= threshold with texton index.
    ``channels``: compare only the first channels of f (e.g. without detail sprites)."""
    _one(t)
    f = torch.nn.functional.normalize(t.f[0, :, :channels], dim=-1)
    return (f @ f[index] >= threshold) & (t.delta[0] > 0.5)


def transform_each(t: Textons, mask: Tensor, A: Tensor, shift=(0.0, 0.0)) -> Textons:
    """Apply x -> A (x - mu_i) + mu_i + shift to every selected texton i (about its centre)."""
    _one(t)
    A = torch.as_tensor(A, dtype=t.dtype)
    m = mask.reshape(1, -1)
    eye = torch.eye(2, dtype=t.dtype)
    A_all = torch.where(m[..., None, None], A, eye)            # (1, K, 2, 2)
    shift = torch.as_tensor(shift, dtype=t.dtype)
    moved = t.affine(A_all, (t.mu - (A_all @ t.mu.unsqueeze(-1)).squeeze(-1))
                     + torch.where(m[..., None], shift, torch.zeros(2, dtype=t.dtype)))
    return moved


def move(t: Textons, mask: Tensor, dx: float, dy: float) -> Textons:
    return transform_each(t, mask, torch.eye(2), (dx, dy))


def scale(t: Textons, mask: Tensor, factor: float) -> Textons:
    return transform_each(t, mask, torch.eye(2) * float(factor))


def rotate(t: Textons, mask: Tensor, degrees: float) -> Textons:
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    return transform_each(t, mask, torch.tensor([[c, s], [-s, c]]))


def delete(t: Textons, mask: Tensor) -> Textons:
    """Switch the selected textons off (delta = p = 0); indices of the others stay valid."""
    keep = (~mask).reshape(1, -1).to(t.dtype)
    return replace(t, p=t.p * keep, delta=t.delta * keep)


def duplicate(t: Textons, mask: Tensor, dx: float = 0.0, dy: float = 0.0) -> Textons:
    """Copies of the selected textons, shifted by (dx, dy), drawn on top of everything."""
    copies = t.filter(mask.reshape(1, -1)).translate(dx, dy)
    return Textons.cat([t, copies], dim=1)


_SELECTORS = {"point": lambda t, s, c: select_point(t, *s["point"]),
              "index": lambda t, s, c: select_index(t, s["index"]),
              "region": lambda t, s, c: select_region(t, s["region"]),
              "similar_to": lambda t, s, c: select_similar(t, int(s["similar_to"]),
                                                           float(s.get("threshold", 0.9)), c)}


def apply_edit(t: Textons, edit: dict, channels: int | None = None) -> Textons:
    """Apply one edit dictionary (see the module docstring); ``channels``: how much of f the
    similarity selection compares (:func:`select_similar`)."""
    sel = edit.get("select")
    if not isinstance(sel, dict) or len(set(sel) & set(_SELECTORS)) != 1:
        raise InputError(f"edit needs 'select' with one of {sorted(_SELECTORS)}: {edit}")
    kind = next(k for k in sel if k in _SELECTORS)
    try:
        mask = _SELECTORS[kind](t, sel, channels)
        op = edit.get("op")
        if op == "move":
            return move(t, mask, *edit["by"])
        if op == "scale":
            return scale(t, mask, edit["by"])
        if op == "rotate":
            return rotate(t, mask, edit["degrees"])
        if op == "delete":
            return delete(t, mask)
        if op == "duplicate":
            return duplicate(t, mask, *edit.get("offset", (0.0, 0.0)))
    except (KeyError, TypeError, ValueError, IndexError, OverflowError, RuntimeError) as exc:
        raise InputError(f"bad edit {json.dumps(edit)[:200]}: {exc}") from None
    raise InputError(f"unknown edit op {op!r} (move, scale, rotate, delete, duplicate)")


def apply_edit_list(t: Textons, edits, channels: int | None = None) -> Textons:
    """Apply a list of edits, or the list stored in a JSON file (``channels``: see
    :func:`apply_edit`)."""
    if isinstance(edits, (str, Path)):
        try:
            if Path(edits).stat().st_size > MAX_EDIT_FILE_BYTES:
                raise InputError(f"{edits}: an edit list over {MAX_EDIT_FILE_BYTES} bytes")
            edits = json.loads(Path(edits).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"{edits}: cannot read edit list ({exc})") from None
        except RecursionError:
            raise InputError(f"{edits}: edit list nested too deeply") from None
    if not isinstance(edits, list):
        raise InputError("an edit list is a JSON list of edits")
    check_count(len(edits), MAX_EDITS, "edits in the list")
    for i, edit in enumerate(edits):
        if not isinstance(edit, dict):
            raise InputError(f"edit {i}: each edit is a JSON object, got {str(edit)[:40]}")
        t = apply_edit(t, edit, channels)
        check_count(t.num_textons, MAX_TEXTONS, f"textons after edit {i}")
        if not all(torch.isfinite(x).all() for x in (t.mu, t.cov)):
            raise InputError(f"edit {i} {json.dumps(edit)[:80]}: moves textons out of range")
    return t
