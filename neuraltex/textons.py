"""The texton container: a batch of B sets of K 2D Gaussians (seed 003, eq. 4.2).

Each texton g_i = {delta_i, mu_i, U_i, v_i, f_i} plus its existence probability p_i and a draw
order. Positions follow :mod:`neuraltex.coords` (normalized units, short image side = 1, origin
top-left, x right, y down), so a texton set can be rendered at any resolution.

Shapes (B sets, K textons, C appearance channels):
    mu (B, K, 2)   cov (B, K, 2, 2)   v (B, K, 2)   f (B, K, C)
    p (B, K)       delta (B, K)       order (B, K) int64
A texton with a larger ``order`` is drawn later, i.e. in front (eq. 4.13 composites index n on
top). ``canvas`` is the (width, height) extent, in normalized units, of the image the textons
describe; it is metadata for default sizes and centres, not a clip.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import torch
import torch.nn.functional as F
from torch import Tensor

# Covariance given to padding textons (absent, delta = 0): a small, valid SPD matrix.
_PAD_VAR = 1e-4


@dataclass
class Textons:
    mu: Tensor
    cov: Tensor
    v: Tensor
    f: Tensor
    p: Tensor
    delta: Tensor
    order: Tensor
    canvas: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        B, K = self.p.shape[:2] if self.p.dim() == 2 else (-1, -1)
        expect = {"mu": (B, K, 2), "cov": (B, K, 2, 2), "v": (B, K, 2), "p": (B, K),
                  "delta": (B, K), "order": (B, K)}
        for name, shape in expect.items():
            if tuple(getattr(self, name).shape) != shape:
                raise ValueError(f"Textons.{name}: expected shape {shape}, "
                                 f"got {tuple(getattr(self, name).shape)}")
        if self.f.dim() != 3 or self.f.shape[:2] != (B, K):
            raise ValueError(f"Textons.f: expected (B={B}, K={K}, C), got {tuple(self.f.shape)}")
        if self.order.dtype != torch.int64:
            self.order = self.order.long()
        self.canvas = (float(self.canvas[0]), float(self.canvas[1]))

    # ------------------------------------------------------------------ basics
    @property
    def batch_size(self) -> int:
        return self.p.shape[0]

    @property
    def num_textons(self) -> int:
        return self.p.shape[1]

    @property
    def feature_dim(self) -> int:
        return self.f.shape[2]

    @property
    def device(self) -> torch.device:
        return self.mu.device

    @property
    def dtype(self) -> torch.dtype:
        return self.mu.dtype

    def features(self) -> Tensor:
        """concat(f, v) as splatted by eq. 4.14. Shape: (B, K, C + 2)."""
        return torch.cat([self.f, self.v], dim=-1)

    def exists(self, threshold: float = 0.5) -> Tensor:
        """Effective textons (delta above ``threshold``). Shape: (B, K) bool."""
        return self.delta > threshold

    def num_effective(self, threshold: float = 0.5) -> Tensor:
        """Number of effective textons per set. Shape: (B,) int64."""
        return self.exists(threshold).sum(dim=1)

    def _map(self, fn) -> Textons:
        """Apply ``fn`` to every tensor field (order included)."""
        return replace(self, **{k: fn(getattr(self, k)) for k in _TENSOR_FIELDS})

    def to(self, device=None, dtype=None) -> Textons:
        """Move to a device and/or cast the float fields; ``order`` stays int64."""
        def move(t: Tensor) -> Tensor:
            return t.to(device=device, dtype=dtype if t.is_floating_point() else None)
        return self._map(move)

    def detach(self) -> Textons:
        return self._map(Tensor.detach)

    def clone(self) -> Textons:
        return self._map(Tensor.clone)

    def __getitem__(self, batch_index) -> Textons:
        """Select sets along the batch dimension (an int keeps the batch dimension)."""
        if isinstance(batch_index, int):
            batch_index = slice(batch_index, batch_index + 1 if batch_index != -1 else None)
        return self._map(lambda t: t[batch_index])

    # -------------------------------------------------------------- selection
    def index(self, idx: Tensor) -> Textons:
        """Gather textons by index. ``idx``: (K',) shared by all sets, or (B, K')."""
        idx = torch.as_tensor(idx, device=self.device, dtype=torch.long)
        if idx.dim() == 1:
            idx = idx.unsqueeze(0).expand(self.batch_size, -1)
        if idx.numel() and (idx.min() < 0 or idx.max() >= self.num_textons):
            raise IndexError(f"texton index out of range [0, {self.num_textons})")

        def gather(t: Tensor) -> Tensor:
            shape = idx.shape + t.shape[2:]
            i = idx.reshape(idx.shape + (1,) * (t.dim() - 2)).expand(shape)
            return torch.gather(t, 1, i)

        return self._map(gather)

    def filter(self, keep: Tensor) -> Textons:
        """Keep the textons where ``keep`` (B, K) is true, preserving their order.

        Sets keep different numbers of textons, so the result has K' = max kept count and
        shorter sets are padded with absent textons (p = delta = 0) drawn behind everything.
        """
        keep = keep.to(self.device, torch.bool)
        if keep.shape != self.p.shape:
            raise ValueError(f"keep mask must have shape {tuple(self.p.shape)}")
        if self.batch_size == 1:  # one set: no padding needed, plain boolean indexing
            return self._map(lambda t: t[:, keep[0]])
        counts = keep.sum(dim=1)
        k_new = int(counts.max()) if counts.numel() else 0
        padded = self.pad_to(self.num_textons + k_new)
        # Stable sort puts kept textons first (in original order), then the padding slots.
        slot = torch.arange(k_new, device=self.device).expand(self.batch_size, -1)
        pad_keep = slot < (k_new - counts).unsqueeze(1)  # enough padding to fill every set
        rank = (~torch.cat([keep, pad_keep], dim=1)).to(torch.int8)
        idx = torch.sort(rank, dim=1, stable=True).indices[:, :k_new]
        return padded.index(idx)

    def existing(self, threshold: float = 0.5) -> Textons:
        """Only the effective textons (delta > threshold), compacted as in :meth:`filter`."""
        return self.filter(self.exists(threshold))

    def in_region(self, region) -> Tensor:
        """Which texton centres lie in ``region``. Shape: (B, K) bool.

        ``region`` is a box ``(x0, y0, x1, y1)`` in normalized units, or a boolean mask
        (H, W) or (B, H, W) covering the canvas (pixel grid as in :mod:`neuraltex.coords`).
        """
        x, y = self.mu[..., 0], self.mu[..., 1]
        if isinstance(region, (tuple, list)):
            x0, y0, x1, y1 = (float(c) for c in region)
            return (x >= x0) & (x < x1) & (y >= y0) & (y < y1)
        mask = torch.as_tensor(region, device=self.device).bool()
        if mask.dim() == 2:
            mask = mask.unsqueeze(0).expand(self.batch_size, -1, -1)
        _, h, w = mask.shape
        col = (x / self.canvas[0] * w).floor().long()
        row = (y / self.canvas[1] * h).floor().long()
        inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
        flat = (row.clamp(0, h - 1) * w + col.clamp(0, w - 1))
        return inside & torch.gather(mask.reshape(self.batch_size, -1), 1, flat)

    def pad_to(self, k: int) -> Textons:
        """Append absent textons (p = delta = 0, drawn behind all others) up to K = k."""
        extra = k - self.num_textons
        if extra < 0:
            raise ValueError(f"cannot pad {self.num_textons} textons down to {k}")
        if extra == 0:
            return self
        B, dev, dt = self.batch_size, self.device, self.dtype
        eye = torch.eye(2, device=dev, dtype=dt) * _PAD_VAR
        low = self.order.min() if self.order.numel() else torch.tensor(0, device=dev)
        pad = Textons(
            mu=torch.zeros(B, extra, 2, device=dev, dtype=dt),
            cov=eye.expand(B, extra, 2, 2).clone(),
            v=torch.tensor([1.0, 0.0], device=dev, dtype=dt).expand(B, extra, 2).clone(),
            f=torch.zeros(B, extra, self.feature_dim, device=dev, dtype=self.f.dtype),
            p=torch.zeros(B, extra, device=dev, dtype=self.p.dtype),
            delta=torch.zeros(B, extra, device=dev, dtype=self.delta.dtype),
            order=(low - 1 - torch.arange(extra, device=dev)).expand(B, -1).clone(),
            canvas=self.canvas,
        )
        return Textons.cat([self, pad], dim=1, on_top=False)

    @staticmethod
    def cat(sets: Sequence[Textons], dim: int = 1, on_top: bool = True) -> Textons:
        """Concatenate texton sets.

        ``dim=1`` joins textons of matching batches; with ``on_top`` each later set is drawn in
        front of the earlier ones (its orders are shifted above theirs), otherwise orders are
        kept as they are. ``dim=0`` stacks batches, padding K with absent textons.
        """
        if not sets:
            raise ValueError("nothing to concatenate")
        first = sets[0]
        if dim == 0:
            k = max(s.num_textons for s in sets)
            sets = [s.pad_to(k) for s in sets]
            return first._cat_fields(sets, 0, [s.order for s in sets])
        if dim != 1:
            raise ValueError("dim must be 0 (batch) or 1 (textons)")
        orders, top = [], None
        for s in sets:
            o = s.order
            if on_top and top is not None and o.numel():
                o = o - o.min(dim=1, keepdim=True).values + top + 1
            orders.append(o)
            if o.numel():
                top = o.max(dim=1, keepdim=True).values if top is None else torch.maximum(
                    top, o.max(dim=1, keepdim=True).values)
        return first._cat_fields(sets, 1, orders)

    def _cat_fields(self, sets: Sequence[Textons], dim: int, orders: list[Tensor]) -> Textons:
        fields = {k: torch.cat([getattr(s, k) for s in sets], dim=dim)
                  for k in _TENSOR_FIELDS if k != "order"}
        return Textons(**fields, order=torch.cat(orders, dim=dim), canvas=self.canvas)

    # ------------------------------------------------------------- transforms
    def affine(self, A: Tensor, t: Tensor | Sequence[float] = (0.0, 0.0)) -> Textons:
        """x -> A x + t on every texton: mu' = A mu + t, U' = A U A^T, v' = A v / |A v|.

        ``A`` broadcasts against (B, K, 2, 2) — e.g. (2, 2), (B, 1, 2, 2) — and ``t`` against
        (B, K, 2). Appearance, existence and order are unchanged.
        """
        A = torch.as_tensor(A, device=self.device, dtype=self.dtype)
        t = torch.as_tensor(t, device=self.device, dtype=self.dtype)
        if A.shape[-2:] != (2, 2):
            raise ValueError(f"A must end in (2, 2), got {tuple(A.shape)}")
        # in the textons' own precision, also under autocast (trainer.amp): a covariance
        # rounded to bfloat16 loses its determinant, and the splatting's inverse of it gave
        # non-finite gradients on a third of the full training steps
        with torch.autocast(self.device.type, enabled=False):
            mu = (A @ self.mu.unsqueeze(-1)).squeeze(-1) + t
            cov = A @ self.cov @ A.transpose(-1, -2)
            cov = 0.5 * (cov + cov.transpose(-1, -2))  # keep exactly symmetric
            v = F.normalize((A @ self.v.unsqueeze(-1)).squeeze(-1), dim=-1, eps=1e-12)
        return replace(self, mu=mu, cov=cov, v=v)

    def translate(self, dx: float, dy: float) -> Textons:
        return self.affine(torch.eye(2), (dx, dy))

    def rotate(self, degrees: float, center: Sequence[float] | None = None) -> Textons:
        """Rotate about ``center`` (default: canvas centre); positive turns counter-clockwise
        on screen, as in kornia (y points down)."""
        a = math.radians(degrees)
        c, s = math.cos(a), math.sin(a)
        return self._about(torch.tensor([[c, s], [-s, c]]), center)

    def scale(self, factor: float | Sequence[float],
              center: Sequence[float] | None = None) -> Textons:
        """Scale about ``center`` (default: canvas centre) by a factor or (sx, sy)."""
        sx, sy = (factor, factor) if isinstance(factor, (int, float)) else factor
        return self._about(torch.diag(torch.tensor([float(sx), float(sy)])), center)

    def _about(self, A: Tensor, center: Sequence[float] | None) -> Textons:
        c = torch.tensor(center if center is not None else
                         (self.canvas[0] / 2, self.canvas[1] / 2), dtype=A.dtype)
        return self.affine(A, c - A @ c)


_TENSOR_FIELDS = ("mu", "cov", "v", "f", "p", "delta", "order")


# --------------------------------------------------------------------- ellipse geometry
def ellipse_axes(cov: Tensor, level: float = 1.0) -> tuple[Tensor, Tensor, Tensor]:
    """Semi-axes (a >= b) and angle (radians, of a, from +x towards +y) of the M = level ellipse.

    With o = exp(-M^2) (eq. 4.12), M^2 = x^T U^-1 x = level^2 has semi-axes level*sqrt(eig).
    """
    evals, evecs = torch.linalg.eigh(cov.double())
    a = level * evals[..., 1].clamp_min(0).sqrt()
    b = level * evals[..., 0].clamp_min(0).sqrt()
    angle = torch.atan2(evecs[..., 1, 1], evecs[..., 0, 1])
    return a.float(), b.float(), angle.float()


def ellipse_points(mu: Tensor, cov: Tensor, level: float = 1.0, n: int = 32) -> Tensor:
    """Polyline of the ellipse, (..., n, 2)."""
    a, b, ang = ellipse_axes(cov, level)
    th = torch.linspace(0, 2 * math.pi, n)
    x = a[..., None] * torch.cos(th)
    y = b[..., None] * torch.sin(th)
    c, s = torch.cos(ang)[..., None], torch.sin(ang)[..., None]
    return torch.stack([mu[..., 0:1] + c * x - s * y, mu[..., 1:2] + s * x + c * y], -1)
