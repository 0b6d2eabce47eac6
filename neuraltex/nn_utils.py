"""Small tensor helpers shared by the networks and the edits: padding to a stride, resizing,
blurring, counting."""

from __future__ import annotations

import functools
import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn


def pad_to_multiple(x: torch.Tensor, multiple: int) -> torch.Tensor:
    """Pad ``x`` (B, C, H, W) on the bottom/right so H and W are multiples of ``multiple``.

    Reflection padding (no hard border the network could use as a position cue); replicate
    padding when the image is too small to reflect. Crop back with ``x[..., :H, :W]``.
    """
    h, w = x.shape[-2:]
    ph, pw = (-h) % multiple, (-w) % multiple
    if ph == 0 and pw == 0:
        return x
    mode = "reflect" if ph < h and pw < w else "replicate"
    return F.pad(x, (0, pw, 0, ph), mode=mode)


def resize(x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """Bilinear resize of (B, C, H, W) to ``size``; antialiased when shrinking."""
    if tuple(x.shape[-2:]) == tuple(size):
        return x
    shrink = size[0] < x.shape[-2] or size[1] < x.shape[-1]
    return F.interpolate(x, size=size, mode="bilinear", align_corners=False, antialias=shrink)


def bilinear_sample(x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """``F.interpolate(x, size, mode="bilinear", align_corners=False)`` (no antialiasing) of
    (B, C, H, W); a side shrunk by a whole factor f samples pixel f i + (f - 1) / 2, which is
    one pixel for odd f and the mean of two for even f, computed here from strided slices
    (E_s's attention masks: 32 x 32 -> 4 x 4 took 0.9 ms through the interpolation kernel,
    0.05 ms this way). Equal up to float rounding; other sizes go to F.interpolate."""
    (H, W), (h, w) = x.shape[-2:], size
    if h == 0 or w == 0 or H % h or W % w:
        return F.interpolate(x, size=size, mode="bilinear", align_corners=False)
    (fy, fx) = (H // h, W // w)
    ys = [slice((fy - 1) // 2, None, fy)] + ([slice(fy // 2, None, fy)] if fy % 2 == 0 else [])
    xs = [slice((fx - 1) // 2, None, fx)] + ([slice(fx // 2, None, fx)] if fx % 2 == 0 else [])
    out = sum(x[..., sy, sx] for sy in ys for sx in xs)
    return out / (len(ys) * len(xs)) if len(ys) * len(xs) > 1 else out.clone()


def shrink_short_side(x: torch.Tensor, short: int) -> torch.Tensor:
    """(B, C, H, W) downscaled (antialiased, never enlarged) so its short side is at most
    ``short``; the aspect ratio is kept."""
    H, W = x.shape[-2:]
    if min(H, W) <= short:
        return x
    s = short / min(H, W)
    return resize(x, (max(1, round(H * s)), max(1, round(W * s))))


def sort_last(x: torch.Tensor) -> torch.Tensor:
    """``x`` sorted along its last dimension; differentiable (the gradient follows the
    permutation), like ``torch.sort(x, -1).values``.

    On CPU the order comes from numpy (x86-simd-sort), its rows split over torch's threads:
    a (4, 64, 3481) float32 argsort took 24 ms in one thread and 13 in two, its sort 9.6 and
    5.8, against torch.sort's 40 ms (2 cores, AMD EPYC; the texture loss's bulk). Ties may
    be permuted differently, which changes no value and only which of the tied entries a
    gradient reaches. Other devices use torch.sort."""
    if x.device.type != "cpu" or not x.is_floating_point() or x.dim() == 0:
        return torch.sort(x, dim=-1).values
    if not x.requires_grad:
        return torch.from_numpy(_by_rows(np.sort, _as_numpy(x))).to(x.dtype)
    return x.gather(-1, argsort_last(x))


def argsort_last(x: torch.Tensor) -> torch.Tensor:
    """``torch.argsort(x, dim=-1)`` (long), from numpy on CPU (x86-simd-sort: an (8, 4096)
    float32 array in 0.25 ms against 1.3 ms; the mask loss's point draw). Ties may be
    ordered differently."""
    if x.device.type != "cpu" or not x.is_floating_point() or x.dim() == 0:
        return torch.argsort(x, dim=-1)
    return torch.from_numpy(_by_rows(np.argsort, _as_numpy(x)))


# Below this many elements one thread sorts: splitting costs more than it saves.
_PARALLEL_SORT = 1 << 18


def _by_rows(sort, a: np.ndarray) -> np.ndarray:
    """``sort(a, axis=-1)`` (np.sort or np.argsort) with the rows split over up to
    ``torch.get_num_threads()`` threads (numpy sorts without the GIL)."""
    rows = a.reshape(-1, a.shape[-1]) if a.ndim > 1 else a.reshape(1, -1)
    k = min(torch.get_num_threads(), rows.shape[0])
    if k < 2 or a.size < _PARALLEL_SORT:
        return sort(a, axis=-1)
    out = np.empty(rows.shape, dtype=np.intp if sort is np.argsort else a.dtype)
    bounds = np.linspace(0, rows.shape[0], k + 1).astype(int)

    def part(i: int) -> None:
        lo, hi = bounds[i], bounds[i + 1]
        out[lo:hi] = sort(rows[lo:hi], axis=-1)

    list(_pool(k).map(part, range(k)))
    return out.reshape(a.shape)


@functools.lru_cache(maxsize=4)
def _threads(k: int, pid: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(k, thread_name_prefix="sort")


def _pool(k: int) -> ThreadPoolExecutor:
    """A pool of ``k`` threads for this process (a forked child gets its own)."""
    return _threads(k, os.getpid())


def _as_numpy(x: torch.Tensor) -> np.ndarray:
    x = x.detach()
    return (x if x.dtype in (torch.float32, torch.float64) else x.float()).numpy()


def flush_subnormals(device: torch.device | str) -> None:
    """On a CPU, flush subnormal floats (below 1.2e-38) to zero, for this process's threads
    from now on: x86 computes with them about 100x slower, and the softmax masks of 100
    queries are full of them (the equivariance matching's mask distances: 0.22 s a 64 px
    training step instead of 0.03 s; ``neuraltex fit`` 1.15x, the same pictures)."""
    if torch.device(device).type == "cpu":
        torch.set_flush_denormal(True)


def adam(params, **kwargs) -> torch.optim.Adam:
    """``torch.optim.Adam`` with its fused kernel (CPU and CUDA): one pass over all the
    parameters instead of about eight ops per tensor (the segmenter step's 180 tensors: Adam
    4.7 -> 1.7 ms of a ~60 ms step on CPU). The same update up to float rounding. Parameters
    elsewhere than on CPU or CUDA (where torch >= 2.4 has the kernel), or not floating point,
    get the usual Adam."""
    params = list(params)
    groups = [dict(g, params=list(g["params"])) if isinstance(g, dict) else {"params": [g]}
              for g in params]  # (a group's parameters may come as a one-pass iterator)
    fused = all(p.device.type in ("cpu", "cuda") and p.is_floating_point()
                for g in groups for p in g["params"])
    if all(isinstance(g, dict) for g in params):
        params = groups
    return torch.optim.Adam(params, fused=fused or None, **kwargs)


def load_adam_state(opt: torch.optim.Optimizer, state: dict) -> None:
    """``opt.load_state_dict(state)`` keeping ``opt``'s kernel choice (``fused`` /
    ``foreach``): a state saved by an unfused Adam (older checkpoints) would switch it off."""
    kernels = [{k: g.get(k) for k in ("fused", "foreach")} for g in opt.param_groups]
    opt.load_state_dict(state)
    for group, kernel in zip(opt.param_groups, kernels, strict=True):
        group.update(kernel)


def count_parameters(module: nn.Module, trainable_only: bool = True) -> int:
    """Number of (trainable) scalar parameters of ``module``."""
    return sum(p.numel() for p in module.parameters() if p.requires_grad or not trainable_only)


@functools.lru_cache(maxsize=64)
def _chain_matrix(n_in: int, up: int, crop: int, out: int) -> torch.Tensor:
    """The 1-D linear map of :func:`upsample_crop_resize` along one axis, (out, n_in): the
    same interpolations applied to the identity (bilinear is separable)."""
    eye = torch.eye(n_in, dtype=torch.float64)[:, None, :, None]  # (n_in, 1, n_in, 1)
    x = resize(eye, (up, 1))[:, :, :crop]  # (n_in, 1, crop, 1)
    x = F.interpolate(x, size=(out, 1), mode="bilinear", align_corners=False)
    return x[:, 0, :, 0].T.contiguous()  # (out, n_in)


def upsample_crop_resize(x: torch.Tensor, up: tuple[int, int], crop: tuple[int, int],
                         out: tuple[int, int]) -> torch.Tensor:
    """``F.interpolate(resize(x, up)[..., :crop_h, :crop_w], out, bilinear)`` for an enlarging
    ``up``, computed as two small matrix products instead of through the large ``up``-sized
    map (E_s predicts at stride 4, the estimation runs at half the input size: going through
    the input size cost ~15 % of a segmenter training step). Equal up to float rounding.

    Shape: x (B, C, h, w) -> (B, C, out_h, out_w).
    """
    if up[0] < x.shape[-2] or up[1] < x.shape[-1]:
        raise ValueError(f"upsample_crop_resize only enlarges: {tuple(x.shape[-2:])} -> {up}")
    ry = _chain_matrix(x.shape[-2], up[0], crop[0], out[0]).to(x)  # (out_h, h)
    rx = _chain_matrix(x.shape[-1], up[1], crop[1], out[1]).to(x)  # (out_w, w)
    return ry @ x @ rx.T  # (B, C, out_h, out_w)


def labels_at(labels: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """An (h, w) int label map resampled (nearest) to ``size`` = (H, W)."""
    if labels.shape == tuple(size):
        return labels
    lab = torch.from_numpy(np.ascontiguousarray(labels)).float()[None, None]
    return F.interpolate(lab, size=tuple(size), mode="nearest")[0, 0].long().numpy()


def blur(x: torch.Tensor, sigma: float, mode: str = "replicate") -> torch.Tensor:
    """(..., H, W) -> (..., H, W): a separable Gaussian blur of each (H, W) plane; edges
    ``mode`` "replicate", or "circular" (around the torus); sigma 0: unchanged."""
    if sigma <= 0:
        return x
    r = math.ceil(2 * sigma)
    t = torch.arange(-r, r + 1, dtype=x.dtype)
    g = torch.exp(-t ** 2 / (2 * sigma ** 2))
    g = g / g.sum()
    planes = x.reshape(-1, 1, *x.shape[-2:])
    a = F.conv2d(F.pad(planes, (r, r, 0, 0), mode=mode), g.view(1, 1, 1, -1))
    return F.conv2d(F.pad(a, (0, 0, r, r), mode=mode), g.view(1, 1, -1, 1)).reshape(x.shape)
