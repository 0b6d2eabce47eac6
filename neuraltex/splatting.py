"""Gaussian splatting h: textons -> feature grid F_s and max-opacity map F_max.

Seed 003, section 4.3.3:
    M_i^2(p) = (p - mu_i)^T U_i^-1 (p - mu_i)                      eq. 4.11
    o_i(p)   = delta_i exp(-M_i^2(p))                              eq. 4.12
    a_i(p)   = o_i(p) prod_{j in front of i} (1 - o_j(p))          eq. 4.13
    F_s(p)   = sum_i a_i(p) concat(f_i, v_i)                       eq. 4.14
    F_max(p) = max_i o_i(p)                                        (4.3.4.1)

:func:`splat` is the fast path: a custom autograd function that walks the pixels in chunks,
keeps the opacities for the backward pass while they are small (a training batch) and
recomputes them otherwise, so memory stays bounded (never B x K x H x W x C).
:func:`splat_reference` is the plain autograd version it is tested against. Both accept any
output size and window (see :mod:`neuraltex.coords`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import torch
from torch import Tensor

from neuraltex.coords import Window, default_window, pixel_grid
from neuraltex.textons import Textons

# Lower bound on det(U) (normalized units^4): keeps U^-1 finite for degenerate covariances.
_MIN_DET = 1e-14
# Without a cut-off, a texton is skipped on a tile where M^2 > 30 everywhere: its opacity there
# is below exp(-30) ~ 1e-13, far under float32 resolution, so the result is the same.
_SKIP_M2 = 30.0
# exp(-M^2) is evaluated at M^2 <= 87 (exp(-87) = 1.6e-38, the smallest normal floats).
_EXP_M2 = 87.0
# The chunked function keeps the forward's opacities for the backward pass when the
# (tiles, K, pixels) tensors hold at most this many elements (2 x 64 MB in float32), and
# recomputes them chunk by chunk above it.
_KEEP_ELEMENTS = 1 << 24
# Elements per (tiles, K, pixels) working tensor in the chunked function (~8 MB in float32).
_CHUNK_ELEMENTS = 1 << 21
# Tiles per image at most (the tile side grows with the image to respect it).
_MAX_TILES = 256


class Splat(NamedTuple):
    features: Tensor     # (B, C + 2, H, W): F_s, concat(f, v) alpha-composited
    max_opacity: Tensor  # (B, 1, H, W): F_max


def splat(textons: Textons, size: tuple[int, int], *, window: Window | None = None,
          cutoff: float | None = None) -> Splat:
    """Render ``textons`` into an H x W feature grid (eqs. 4.11-4.14).

    ``cutoff``: optional Mahalanobis cut-off; opacity is 0 where M > cutoff (the authors'
    release uses 3). Differentiable w.r.t. mu, cov, delta, f and v.

    The image is cut into square tiles; each tile composites only the textons whose ellipse
    (at M^2 = cutoff^2, or 30 without a cut-off) reaches it, in draw order. Opacities are kept
    for the backward pass up to _KEEP_ELEMENTS and recomputed in it above that.
    """
    mu, prec, delta, feats, (H, W), window = _prepare(textons, size, window)
    B, K, C = feats.shape
    tiles = _tiles(mu, prec, H, W, window, cutoff)
    delta_t = tiles.gather(delta) * tiles.valid
    chunk = max(1, _CHUNK_ELEMENTS // max(1, tiles.idx.shape[-1] * tiles.side ** 2))
    out, fmax = _SplatFunction.apply(tiles.gather(mu), tiles.gather(prec), delta_t,
                                     tiles.gather(feats), tiles.grid, cutoff, chunk)
    return Splat(tiles.untile(out, H, W), tiles.untile(fmax.unsqueeze(1), H, W))


def weighted_sums(textons: Textons, values: Tensor, *, window: Window | None = None,
                  cutoff: float | None = None) -> Tensor:
    """sum_p a_i(p) values(p) for every texton i: the composited weights (eq. 4.13) summed
    against a map, without materializing the (K, H*W) weights. The splat is linear in the
    features, F -> sum_i a_i F_i, so these sums are its vector-Jacobian product with
    ``values`` (tiled like :func:`splat`). values (B, C, H, W) -> (B, K, C)."""
    from dataclasses import replace

    B, C, H, W = values.shape
    with torch.enable_grad():
        f = values.new_zeros(B, textons.num_textons, C, requires_grad=True)
        out = splat(replace(textons.detach(), f=f), (H, W), window=window, cutoff=cutoff)
        (g,) = torch.autograd.grad(out.features[:, :C], f, grad_outputs=values)
    return g


def top_weights(textons: Textons, size: tuple[int, int], k: int = 4, *,
                window: Window | None = None, cutoff: float | None = None
                ) -> tuple[Tensor, Tensor]:
    """The ``k`` largest composited weights a_i(p) (eq. 4.13) at every pixel, and which
    textons give them (in the textons' own index order): (B, k, H, W) float, (B, k, H, W)
    int64. Pixels reached by fewer than k textons get weight 0 (index 0) in the rest. Tiled
    like :func:`splat`, so memory stays O(B*K*chunk); no gradients."""
    with torch.no_grad():
        mu, prec, delta, _, (H, W), window = _prepare(textons, size, window)
        tiles = _tiles(mu, prec, H, W, window, cutoff)
        mu_t, prec_t = tiles.gather(mu), tiles.gather(prec)
        delta_t = tiles.gather(delta) * tiles.valid
        N, Kt = delta_t.shape
        chunk = max(1, _CHUNK_ELEMENTS // max(1, Kt * tiles.side ** 2))
        P = tiles.grid.shape[1]
        weights = mu.new_zeros(N, k, P)
        index = torch.zeros(N, k, P, dtype=torch.int64, device=mu.device)
        for s in range(0, N, chunk):
            e = s + chunk
            o = _opacity(mu_t[s:e], prec_t[s:e], delta_t[s:e], tiles.grid[s:e], cutoff)
            a = o * _transmittance(o)                                    # (n, Kt, P)
            w, i = a.topk(min(k, Kt), dim=1)
            weights[s:e, :w.shape[1]] = w
            index[s:e, :w.shape[1]] = torch.gather(tiles.idx.reshape(N, Kt)[s:e], 1,
                                                   i.flatten(1)).reshape(i.shape)
        order = _front_to_back(textons)                                  # sorted -> own
        index = torch.gather(order, 1, index.reshape(order.shape[0], -1)).reshape(index.shape)
        return (tiles.untile(weights, H, W), tiles.untile(index, H, W))


class _Tiles(NamedTuple):
    """Square tiles of an image and the textons that reach each (front-most first)."""
    grid: Tensor   # (B*T, P, 2) pixel centres of each tile
    idx: Tensor    # (B, T, Kt) texton indices (into the sorted set) per tile
    valid: Tensor  # (B*T, Kt) float: 1 where idx is a real entry
    side: int
    ty: int
    tx: int

    def gather(self, x: Tensor) -> Tensor:
        """(B, K, ...) per-texton values -> (B*T, Kt, ...) per tile."""
        B, T, Kt = self.idx.shape
        flat = self.idx.reshape(B, T * Kt)
        i = flat.reshape(B, T * Kt, *([1] * (x.dim() - 2))).expand(B, T * Kt, *x.shape[2:])
        return torch.gather(x, 1, i).reshape(B * T, Kt, *x.shape[2:])

    def untile(self, x: Tensor, H: int, W: int) -> Tensor:
        """(B*T, C, P) per-tile values -> (B, C, H, W) image, cropping the overhang."""
        B, s = self.idx.shape[0], self.side
        x = x.reshape(B, self.ty, self.tx, x.shape[1], s, s)
        img = x.permute(0, 3, 1, 4, 2, 5).reshape(B, x.shape[3], self.ty * s, self.tx * s)
        return img[:, :, :H, :W]


def _tiles(mu: Tensor, prec: Tensor, H: int, W: int, window: Window,
           cutoff: float | None) -> _Tiles:
    """Cut an H x W image (in ``window``) into at most _MAX_TILES square tiles and list the
    textons (M^2 <= cutoff^2, or 30) that reach each."""
    B = mu.shape[0]
    side = max(16, math.ceil(math.sqrt(H * W / _MAX_TILES)))
    ty, tx = math.ceil(H / side), math.ceil(W / side)
    px, py = (window[2] - window[0]) / W, (window[3] - window[1]) / H
    # Tiles keep the pixel pitch of the image and run past its border if needed.
    tile_window = (window[0], window[1], window[0] + tx * side * px, window[1] + ty * side * py)
    grid = pixel_grid(ty * side, tx * side, tile_window, device=mu.device, dtype=mu.dtype)
    grid = grid.reshape(ty, side, tx, side, 2).permute(0, 2, 1, 3, 4)  # (ty, tx, s, s, 2)
    grid = grid.reshape(ty * tx, side * side, 2)                         # (T, P, 2)
    r2 = _SKIP_M2 if cutoff is None else min(cutoff * cutoff, _SKIP_M2)
    idx, valid = _tile_lists(mu, prec, grid, r2)                          # (B, T, Kt)
    T, Kt = idx.shape[1], idx.shape[2]
    grid_t = grid.unsqueeze(0).expand(B, -1, -1, -1).reshape(B * T, side * side, 2)
    return _Tiles(grid_t, idx, valid.reshape(B * T, Kt).to(mu.dtype), side, ty, tx)


def _tile_lists(mu: Tensor, prec: Tensor, grid: Tensor, r2: float) -> tuple[Tensor, Tensor]:
    """Per tile, the textons whose M^2 <= r2 ellipse box meets it, front-most first.

    mu (B, K, 2), prec (B, K, 3), grid (T, P, 2) -> idx (B, T, Kt) int64, valid (B, T, Kt)
    bool, where Kt is the largest count over tiles (short lists padded with invalid entries).
    """
    with torch.no_grad():
        det = (prec[..., 0] * prec[..., 2] - prec[..., 1] ** 2).clamp_min(1e-30)
        half = torch.stack([prec[..., 2] / det, prec[..., 0] / det], -1).mul(r2).sqrt()  # (B,K,2)
        lo, hi = grid.amin(dim=1), grid.amax(dim=1)  # (T, 2) pixel-centre extent per tile
        near = torch.minimum(torch.maximum(mu.unsqueeze(1), lo[:, None]), hi[:, None])
        hit = ((near - mu.unsqueeze(1)).abs() <= half.unsqueeze(1)).all(dim=-1)  # (B, T, K)
        kt = max(1, int(hit.sum(dim=-1).max()))
        order = torch.sort((~hit).to(torch.int8), dim=-1, stable=True).indices[..., :kt]
        return order, torch.gather(hit, -1, order)


def splat_reference(textons: Textons, size: tuple[int, int], *, window: Window | None = None,
                    cutoff: float | None = None) -> Splat:
    """Plain-autograd splatting, materializing (B, K, H*W) opacities. For tests and debugging."""
    mu, prec, delta, feats, (H, W), window = _prepare(textons, size, window)
    B, K, C = feats.shape
    grid = pixel_grid(H, W, window, device=mu.device, dtype=mu.dtype)  # (HW, 2)
    o = _opacity(mu, prec, delta, grid, cutoff)  # (B, K, HW), front-most texton first
    alpha = o * _transmittance(o)
    out = feats.transpose(1, 2) @ alpha  # (B, C, HW)
    return Splat(out.reshape(B, C, H, W), o.amax(dim=1).reshape(B, 1, H, W))


def opacity_maps(textons: Textons, size: tuple[int, int], *, window: Window | None = None,
                 cutoff: float | None = None, composite: bool = True) -> Tensor:
    """Per-texton maps, in the textons' own index order. Shape: (B, K, H, W).

    With ``composite`` these are the alpha-composited weights a_i (eq. 4.13) — what each texton
    contributes to each pixel, e.g. for overlays and vectorization; otherwise the raw o_i.
    """
    mu, prec, delta, _, (H, W), window = _prepare(textons, size, window)
    grid = pixel_grid(H, W, window, device=mu.device, dtype=mu.dtype)  # (HW, 2)
    o = _opacity(mu, prec, delta, grid, cutoff)
    maps = o * _transmittance(o) if composite else o
    inverse = torch.argsort(_front_to_back(textons), dim=1)  # back to index order
    maps = torch.gather(maps, 1, inverse.unsqueeze(-1).expand_as(maps))
    return maps.reshape(textons.batch_size, textons.num_textons, H, W)


def precision(cov: Tensor) -> Tensor:
    """U^-1 of 2x2 covariances as (p00, p01, p11), with det(U) clamped. (..., 2, 2) -> (..., 3)."""
    a, d = cov[..., 0, 0], cov[..., 1, 1]
    b = 0.5 * (cov[..., 0, 1] + cov[..., 1, 0])
    det = (a * d - b * b).clamp_min(_MIN_DET)
    return torch.stack([d / det, -b / det, a / det], dim=-1)


def _front_to_back(textons: Textons) -> Tensor:
    """Indices sorting each set front-most first (largest order first). (B, K)."""
    return torch.argsort(textons.order, dim=1, descending=True, stable=True)


def _prepare(textons: Textons, size: tuple[int, int], window: Window | None):
    H, W = int(size[0]), int(size[1])
    window = default_window(H, W) if window is None else window
    dtype = torch.promote_types(textons.dtype, torch.float32)
    t = textons.index(_front_to_back(textons)).to(dtype=dtype)
    return t.mu, precision(t.cov), t.delta, t.features(), (H, W), window


def _mahalanobis(mu: Tensor, prec: Tensor, grid: Tensor) -> Tensor:
    """Squared Mahalanobis distance M^2 (eq. 4.11).

    mu (N, K, 2), prec (N, K, 3), grid (P, 2) or (N, P, 2) -> (N, K, P).
    """
    dx = grid[..., 0].unsqueeze(-2) - mu[..., 0:1]
    dy = grid[..., 1].unsqueeze(-2) - mu[..., 1:2]
    p00, p01, p11 = (prec[..., i:i + 1] for i in range(3))
    m2 = dx * torch.addcmul(p00 * dx, 2 * p01, dy)  # dx (p00 dx + 2 p01 dy) + p11 dy^2
    return m2.addcmul_(p11 * dy, dy)


def _gaussian(mu: Tensor, prec: Tensor, grid: Tensor, cutoff: float | None) -> Tensor:
    """exp(-M^2) (eq. 4.12 without delta), zero beyond the cut-off. (N, K, P)."""
    m2 = _mahalanobis(mu, prec, grid)
    # exp of arguments below -87 (results under the smallest normal float) takes a slow path
    # on x86, 15-35x slower; most (texton, pixel) pairs of a tile are that far.
    g = torch.exp(-m2.clamp_max(_EXP_M2))
    if cutoff is not None:
        g = g * (m2 <= cutoff * cutoff)
    return g


def _opacity(mu: Tensor, prec: Tensor, delta: Tensor, grid: Tensor,
             cutoff: float | None) -> Tensor:
    """o_i = delta_i exp(-M^2) (eq. 4.12), zero beyond the cut-off. (B, K, P)."""
    return delta.unsqueeze(-1) * _gaussian(mu, prec, grid, cutoff)


def _transmittance(o: Tensor) -> Tensor:
    """prod_{j<k}(1 - o_j) along K for front-to-back sorted opacities (eq. 4.13). (B, K, P)."""
    if o.requires_grad:  # the plain-autograd path (splat_reference)
        T = torch.cumprod(1 - o, dim=1)
        return torch.cat([torch.ones_like(T[:, :1]), T[:, :-1]], dim=1)
    # The same products in the same order, one slice at a time: 3.5x faster than cumprod
    # along a middle dimension on CPU.
    T, q = torch.empty_like(o), 1 - o
    T[:, :1] = 1
    for k in range(1, o.shape[1]):
        torch.mul(T[:, k - 1], q[:, k - 1], out=T[:, k])
    return T


class _SplatFunction(torch.autograd.Function):
    """Eqs. 4.11-4.14 over N independent (textons, pixels) items, e.g. image tiles, walked in
    chunks of items, with a hand-written backward. The backward reuses the forward's
    Gaussians and transmittances when they are small enough to keep (_KEEP_ELEMENTS) and
    recomputes them chunk by chunk otherwise.

    mu (N, K, 2), prec (N, K, 3), delta (N, K), feats (N, K, C), grid (N, P, 2)
    -> out (N, C, P), fmax (N, P).
    """

    @staticmethod
    @torch.amp.custom_fwd(device_type="cuda", cast_inputs=torch.float32)
    def forward(ctx, mu, prec, delta, feats, grid, cutoff, chunk):
        N, K, C = feats.shape
        P = grid.shape[1]
        out = feats.new_empty(N, C, P)
        fmax = feats.new_zeros(N, P)
        keep = any(ctx.needs_input_grad[:4]) and N * K * P <= _KEEP_ELEMENTS
        ctx.kept = [] if keep else None
        for s in range(0, N, chunk):
            e = s + chunk
            g = _gaussian(mu[s:e], prec[s:e], grid[s:e], cutoff)
            o = delta[s:e].unsqueeze(-1) * g                               # (n, K, P)
            T = _transmittance(o)
            torch.bmm(feats[s:e].transpose(1, 2), o * T, out=out[s:e])
            if K and keep:
                fmax[s:e], top = o.max(dim=1)
                ctx.kept.append((g, T, top))
            elif K:
                fmax[s:e] = o.amax(dim=1)
        ctx.save_for_backward(mu, prec, delta, feats, grid)
        ctx.cutoff, ctx.chunk = cutoff, chunk
        return out, fmax

    @staticmethod
    @torch.amp.custom_bwd(device_type="cuda")
    def backward(ctx, g_out, g_fmax):
        mu, prec, delta, feats, grid = ctx.saved_tensors
        cutoff, chunk = ctx.cutoff, ctx.chunk
        g_mu, g_prec = torch.zeros_like(mu), torch.zeros_like(prec)
        g_delta, g_feats = torch.zeros_like(delta), torch.zeros_like(feats)
        if feats.shape[1] == 0:
            return g_mu, g_prec, g_delta, g_feats, None, None, None
        if g_out is None:
            g_out = feats.new_zeros(feats.shape[0], feats.shape[2], grid.shape[1])
        for c, s in enumerate(range(0, feats.shape[0], chunk)):
            e = s + chunk
            pr = prec[s:e]
            if ctx.kept:  # the forward's Gaussians, transmittances and front-most textons
                g, T, top = ctx.kept[c]
                o = delta[s:e].unsqueeze(-1) * g
            else:
                g = _gaussian(mu[s:e], pr, grid[s:e], cutoff)
                o = delta[s:e].unsqueeze(-1) * g
                T = _transmittance(o)
                top = o.max(dim=1).indices if g_fmax is not None else None
            go = g_out[s:e]                                  # (n, C, P)
            g_feats[s:e] = (o * T) @ go.transpose(1, 2)      # (n, K, C)
            g_alpha = feats[s:e] @ go                        # (n, K, P): dL/da_k
            g_o = T * (g_alpha - _behind(g_alpha, o))        # dL/do_k through eq. 4.13
            if g_fmax is not None:
                g_o.scatter_add_(1, top.unsqueeze(1), g_fmax[s:e].unsqueeze(1))
            g_delta[s:e] = (g_o * g).sum(-1)
            g_m2 = -g_o * o                                  # d o / d M^2 = -o
            sx, sy, sxx, sxy, syy = _offset_moments(g_m2, mu[s:e], grid[s:e])
            g_prec[s:e] = torch.stack([sxx, 2 * sxy, syy], dim=-1)  # dM^2/dprec (eq. 4.11)
            wx = pr[..., 0] * sx + pr[..., 1] * sy
            wy = pr[..., 1] * sx + pr[..., 2] * sy
            g_mu[s:e] = -2 * torch.stack([wx, wy], dim=-1)
        return g_mu, g_prec, g_delta, g_feats, None, None, None


def _offset_moments(w: Tensor, mu: Tensor, grid: Tensor) -> tuple[Tensor, ...]:
    """sum_p w (dx, dy, dx^2, dx dy, dy^2) with d = grid_p - mu_k, from one product of ``w``
    with the pixels' monomials (x, y about the grid's mean, so nothing large cancels)
    instead of five passes over (N, K, P): the splatting backward's gradients of the
    precisions and means. w (N, K, P), mu (N, K, 2), grid (N, P, 2) -> five (N, K)."""
    c = grid.mean(dim=1, keepdim=True)  # (N, 1, 2)
    x, y = (grid - c).unbind(-1)  # (N, P) each
    mono = torch.stack([torch.ones_like(x), x, y, x * x, x * y, y * y], dim=-1)  # (N, P, 6)
    s1, s_x, s_y, s_xx, s_xy, s_yy = torch.bmm(w, mono.to(w.dtype)).unbind(-1)  # (N, K)
    mx, my = (mu - c).unbind(-1)
    sx, sy = s_x - mx * s1, s_y - my * s1
    sxx = s_xx - 2 * mx * s_x + mx * mx * s1
    sxy = s_xy - mx * s_y - my * s_x + mx * my * s1
    syy = s_yy - 2 * my * s_y + my * my * s1
    return sx, sy, sxx, sxy, syy


def _behind(g_alpha: Tensor, o: Tensor) -> Tensor:
    """B_k = sum_{m>k} g_alpha_m o_m prod_{k<j<m} (1 - o_j), by a back-to-front recurrence.

    This is what texton k's transmittance takes away from the textons behind it, computed
    without dividing by (1 - o_k), which may be 0. (B, K, p) -> (B, K, p).
    """
    acc = torch.zeros_like(g_alpha)
    run = torch.zeros_like(g_alpha[:, 0])
    for k in range(o.shape[1] - 1, 0, -1):
        run = g_alpha[:, k] * o[:, k] + (1 - o[:, k]) * run
        acc[:, k - 1] = run
    return acc
