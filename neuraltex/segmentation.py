"""E_s: a small query-based segmentation head, Mask2Former style (seed 003, 4.3.2.2, 7.7.1).

image -> backbone (strides 4, 8, 16, 32) -> FPN pixel decoder -> per-pixel mask embeddings at
stride 4 plus three memory levels (strides 32, 16, 8) -> transformer decoder with n learned
queries (masked cross-attention, self-attention, FFN; levels visited round-robin) -> mask logits
= query embedding . per-pixel embedding -> upsampled to the input size -> softmax over the n
queries per pixel (S in the paper).

Differences from Mask2Former, on purpose: an FPN instead of the multi-scale deformable-attention
pixel decoder; no class head (textons are the only class; existence comes from eq. 4.5);
``attn_mask_mode="softmax"`` (default for tiny/small) blocks pixel p for query q when
S_q(p) < 1/n, which is shift-invariant like the softmax the rest of the model sees, while
``"sigmoid"`` (paper preset) is Mask2Former's rule sigmoid(logit) < 0.5. As in Mask2Former a
query whose mask blocks every pixel of a level may attend everywhere on it.

Resolution: any input size; sides are padded (reflection) to a multiple of :attr:`stride` = 32
internally and outputs are cropped back. Logits are predicted at stride 4 (the final ones at
stride 2 or 1 with ``mask_stride``, :class:`neuraltex.mask_upsampler.MaskUpsampler`) and upsampled
bilinearly to the input size. The ResNet-50 backbone keeps torchvision's BatchNorm, so in
training mode it needs batch * (H/32) * (W/32) > 1; the small backbone uses GroupNorm.
At 32x32 the stride-32 memory is a single token: its cross-attention softmax is then constant,
so those layers' query/key projections get no gradient from that level (harmless).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Literal

import torch
import torch.nn.functional as F
from torch import nn

from neuraltex.backbones import ResNet50Backbone, SmallBackbone, group_norm
from neuraltex.mask_upsampler import MaskUpsampler
from neuraltex.nn_utils import bilinear_sample, pad_to_multiple, resize, upsample_crop_resize
from neuraltex.small_attention import small_attention


@dataclass
class SegmentationConfig:
    in_channels: int = 3
    num_queries: int = 100
    backbone: Literal["small", "resnet50"] = "resnet50"
    backbone_channels: tuple[int, ...] = (32, 64, 128, 256)  # only for backbone="small"
    backbone_weights: str | None = None  # local ResNet-50 state_dict file; never downloaded
    conv_dim: int = 256
    mask_dim: int = 256
    hidden_dim: int = 256
    num_heads: int = 8
    ffn_dim: int = 2048
    num_layers: int = 4
    attn_mask_mode: Literal["sigmoid", "softmax"] = "sigmoid"
    mask_pos_scale: float = 0.0  # weak positional encoding added to the mask features
    anchor_prior: bool = False  # queries start as a grid of soft local masks (see AnchorPrior)
    mask_stride: int = 4  # final mask logits at stride 4 (FPN), or 2 / 1 (MaskUpsampler)

    @classmethod
    def preset(cls, name: str) -> SegmentationConfig:
        presets = {
            "tiny": cls(num_queries=16, backbone="small", backbone_channels=(16, 24, 32, 48),
                        conv_dim=32, mask_dim=32, hidden_dim=32, num_heads=4, ffn_dim=64,
                        attn_mask_mode="softmax", mask_pos_scale=0.1, anchor_prior=True),
            "small": cls(num_queries=32, backbone="small", backbone_channels=(32, 64, 128, 256),
                         conv_dim=64, mask_dim=64, hidden_dim=64, num_heads=4, ffn_dim=256,
                         attn_mask_mode="softmax", mask_pos_scale=0.1, anchor_prior=True),
            "paper": cls(),
        }
        return presets[name]


@dataclass
class SegmentationOutput:
    logits: torch.Tensor  # (B, n, H, W) mask logits at input resolution (or ``out_size``)
    # with aux=True: predictions from the initial queries and after each layer (num_layers + 1,
    # the last is the final one unless mask_stride < 4) at stride 4 of the padded input,
    # (B, n, H'/4, W'/4), for deep supervision
    aux_logits: list[torch.Tensor] = field(default_factory=list)
    attn_masks: list[torch.Tensor] = field(default_factory=list)  # per layer, (B, n, L) blocked
    attn_weights: list[torch.Tensor] = field(default_factory=list)  # per layer, (B, heads, n, L)

    @property
    def masks(self) -> torch.Tensor:
        """(B, n, H, W) S = softmax over the n queries (computed on demand: training only
        needs the logits)."""
        return self.logits.softmax(dim=1)


# ----------------------------------------------------------------------------- pixel decoder


class FPNPixelDecoder(nn.Module):
    """Top-down FPN. Returns mask features (stride 4) and memories at strides 32, 16, 8."""

    def __init__(self, in_channels: tuple[int, ...], conv_dim: int, mask_dim: int) -> None:
        super().__init__()
        self.lateral = nn.ModuleList(
            nn.Sequential(nn.Conv2d(c, conv_dim, 1, bias=False), group_norm(conv_dim))
            for c in in_channels
        )
        self.output = nn.ModuleList(
            nn.Sequential(nn.Conv2d(conv_dim, conv_dim, 3, 1, 1, bias=False), group_norm(conv_dim),
                          nn.ReLU())
            for _ in in_channels
        )
        self.mask_proj = nn.Conv2d(conv_dim, mask_dim, 3, 1, 1)

    def forward(self, feats: list[torch.Tensor]) -> tuple[torch.Tensor, list[torch.Tensor]]:
        outs: list[torch.Tensor] = []
        y = None
        for i in reversed(range(len(feats))):  # stride 32 -> 4
            lat = self.lateral[i](feats[i])  # (B, conv_dim, h_i, w_i)
            y = lat if y is None else lat + F.interpolate(y, size=lat.shape[-2:], mode="nearest")
            y = self.output[i](y)
            outs.append(y)
        mask_features = self.mask_proj(outs[-1])  # (B, mask_dim, H/4, W/4)
        return mask_features, outs[:3]  # memories at strides 32, 16, 8


def sine_position_encoding(h: int, w: int, dim: int, device=None, dtype=None) -> torch.Tensor:
    """DETR-style normalised sine/cosine encoding of pixel centres. Shape: (dim, h, w).

    Coordinates are normalised to [0, 2*pi] so the encoding is resolution-independent. A
    constant of its arguments, computed once per (h, w, dim, device, dtype): callers must not
    write into it.
    """
    return _sine_position_encoding(h, w, dim, torch.device(device or "cpu"),
                                   dtype or torch.float32)


@functools.lru_cache(maxsize=64)
def _sine_position_encoding(h: int, w: int, dim: int, device: torch.device,
                            dtype: torch.dtype) -> torch.Tensor:
    with torch.inference_mode(False), torch.no_grad():  # a plain tensor, also when first
        npf = dim // 2                                   # asked for under inference mode
        y = (torch.arange(h, device=device, dtype=torch.float32) + 0.5) / h * 2 * math.pi
        x = (torch.arange(w, device=device, dtype=torch.float32) + 0.5) / w * 2 * math.pi
        k = torch.arange(npf, device=device)
        freq = 10000 ** (2 * (k // 2) / npf)  # (npf,) DETR frequencies
        even = (k % 2 == 0)  # sin on even channels, cos on odd ones
        py, px = y[:, None] / freq, x[:, None] / freq  # (h, npf), (w, npf)
        py = torch.where(even, py.sin(), py.cos())  # (h, npf)
        px = torch.where(even, px.sin(), px.cos())  # (w, npf)
        pos = torch.cat((py[:, None, :].expand(h, w, npf), px[None, :, :].expand(h, w, npf)),
                        dim=2)
        pos = F.pad(pos, (0, dim - 2 * npf))  # odd dim: one zero channel
        return pos.permute(2, 0, 1).to(dtype).contiguous()  # (dim, h, w)


# ----------------------------------------------------------------------------- transformer


SMALL_KEYS = 128  # keys up to which :func:`small_attention` beats the fused kernel


def masked_attention(
    q: torch.Tensor, k: torch.Tensor, v: torch.Tensor, blocked: torch.Tensor | None = None,
    need_weights: bool = True,
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Scaled dot-product attention with a boolean mask (True = may not attend).

    Shape: q (B, h, n, d), k/v (B, h, L, d), blocked (B, n, L) or (B, h, n, L)
    -> out (B, h, n, d), weights (B, h, n, L). Blocked entries get exactly zero weight; every
    row must have an entry that is not blocked. Without ``need_weights`` the weights are None
    and the output is computed without them: on the CPU by :func:`small_attention`
    (closed-form backward) for up to :data:`SMALL_KEYS` keys (1.6-3x faster forward +
    backward than torch's fused kernel there, slower on longer sequences; never timed on a
    GPU), else by the fused kernel (1.3-1.9x faster than the explicit softmax).
    """
    if blocked is not None and blocked.dim() == 3:
        blocked = blocked[:, None]  # (B, 1, n, L)
    if not need_weights and k.shape[-2] <= SMALL_KEYS and q.device.type == "cpu":
        return small_attention(q, k, v, blocked), None
    if not need_weights:
        mask = None if blocked is None else ~blocked  # SDPA's boolean mask: True = attend
        return F.scaled_dot_product_attention(q, k, v, attn_mask=mask), None
    scores = q @ k.transpose(-2, -1) / math.sqrt(q.shape[-1])  # (B, h, n, L)
    if blocked is not None:
        scores = scores.masked_fill(blocked, float("-inf"))
    weights = scores.softmax(dim=-1)
    return weights @ v, weights


class Attention(nn.Module):
    """Multi-head attention with separate q/k/v projections and an optional boolean mask."""

    def __init__(self, dim: int, num_heads: int) -> None:
        super().__init__()
        if dim % num_heads:
            raise ValueError("dim must be divisible by num_heads")
        self.h = num_heads
        self.q, self.k, self.v, self.out = (nn.Linear(dim, dim) for _ in range(4))

    def forward(self, query, key, value, blocked=None, need_weights: bool = True
                ) -> tuple[torch.Tensor, torch.Tensor | None]:
        b, n, d = query.shape
        split = lambda t: t.view(b, t.shape[1], self.h, d // self.h).transpose(1, 2)  # noqa: E731
        q, k, v = split(self.q(query)), split(self.k(key)), split(self.v(value))  # (B, h, *, d/h)
        out, w = masked_attention(q, k, v, blocked, need_weights)  # (B, h, n, d/h)
        return self.out(out.transpose(1, 2).reshape(b, n, d)), w  # (B, n, d)


class DecoderLayer(nn.Module):
    """Mask2Former decoder layer (post-norm): masked cross-attn -> self-attn -> FFN."""

    def __init__(self, dim: int, num_heads: int, ffn_dim: int) -> None:
        super().__init__()
        self.cross, self.self_attn = Attention(dim, num_heads), Attention(dim, num_heads)
        self.ffn = nn.Sequential(nn.Linear(dim, ffn_dim), nn.ReLU(), nn.Linear(ffn_dim, dim))
        self.norm1, self.norm2, self.norm3 = (nn.LayerNorm(dim) for _ in range(3))

    def forward(self, tgt, query_pos, memory, memory_pos, blocked, need_weights: bool = True):
        """-> (queries (B, n, D), cross-attention weights (B, heads, n, L) or None)."""
        out, w = self.cross(tgt + query_pos, memory + memory_pos, memory, blocked, need_weights)
        tgt = self.norm1(tgt + out)  # (B, n, D)
        q = tgt + query_pos
        tgt = self.norm2(tgt + self.self_attn(q, q, tgt, need_weights=False)[0])
        tgt = self.norm3(tgt + self.ffn(tgt))
        return tgt, w


class MaskHead(nn.Module):
    """Queries (B, n, D) + mask features (B, C, h, w) -> mask logits (B, n, h, w)."""

    def __init__(self, hidden_dim: int, mask_dim: int) -> None:
        super().__init__()
        self.norm = nn.LayerNorm(hidden_dim)
        self.embed = nn.Sequential(
            nn.Linear(hidden_dim, hidden_dim), nn.ReLU(),
            nn.Linear(hidden_dim, hidden_dim), nn.ReLU(),
            nn.Linear(hidden_dim, mask_dim),
        )

    def forward(self, queries: torch.Tensor, mask_features: torch.Tensor) -> torch.Tensor:
        emb = self.embed(self.norm(queries))  # (B, n, C)
        return torch.einsum("bnc,bchw->bnhw", emb, mask_features)  # (B, n, h, w)


class AnchorPrior(nn.Module):
    """A locality prior on the mask logits, our addition for short (CPU) training runs.

    Query q owns an anchor a_q on a rows x cols grid over the image (relative coordinates);
    from its embedding it predicts an offset (up to 2 cells) and a spread s_q, and its mask
    logit gets  -|(p - c_q) / cell|^2 / (2 s_q^2)  with c_q = a_q + offset. At initialization
    the masks are therefore a soft grid partition, and the learned part (query . pixel
    embedding) only has to move boundaries onto the textons, which a plain Mask2Former head
    learns only after ~1e5 steps. Queries (B, n, D) -> prior (B, n, h, w) on an h x w grid
    covering ``valid`` = the unpadded fraction (fy, fx) of it.
    """

    def __init__(self, num_queries: int, hidden_dim: int) -> None:
        super().__init__()
        rows = max(1, round(math.sqrt(num_queries)))
        cols = math.ceil(num_queries / rows)
        k = torch.arange(num_queries)
        anchors = torch.stack([(k % cols + 0.5) / cols, (k // cols + 0.5) / rows], -1)
        self.register_buffer("anchors", anchors, persistent=False)  # (n, 2) as (x, y)
        self.register_buffer("cell", torch.tensor([1.0 / cols, 1.0 / rows]), persistent=False)
        self.head = nn.Linear(hidden_dim, 3)  # offset x, offset y, log spread
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    def terms(self, queries: torch.Tensor, size: tuple[int, int],
              valid: tuple[float, float]) -> tuple[torch.Tensor, torch.Tensor]:
        """The prior's two separable parts: prior = -ty[..., :, None] - tx[..., None, :],
        ty (B, n, h), tx (B, n, w)."""
        h, w = size
        out = self.head(queries)  # (B, n, 3)
        centre = self.anchors + 2 * torch.tanh(out[..., :2]) * self.cell  # (B, n, 2)
        spread = 0.6 * torch.exp(out[..., 2].clamp(-2, 2))  # (B, n) in cells
        ys = _cell_centres(h, valid[0], queries.device, queries.dtype)  # (h,)
        xs = _cell_centres(w, valid[1], queries.device, queries.dtype)  # (w,)
        dx = (xs - centre[..., 0, None]) / self.cell[0]  # (B, n, w)
        dy = (ys - centre[..., 1, None]) / self.cell[1]  # (B, n, h)
        inv = 1 / (2 * spread[..., None] ** 2)  # (B, n, 1)
        return dy ** 2 * inv, dx ** 2 * inv

    def forward(self, queries: torch.Tensor, size: tuple[int, int],
                valid: tuple[float, float]) -> torch.Tensor:
        ty, tx = self.terms(queries, size, valid)
        # separable: one full-size (B, n, h, w) op instead of four
        return -ty[..., :, None] - tx[..., None, :]


@functools.lru_cache(maxsize=64)
def _cell_centres(size: int, valid: float, device: torch.device, dtype: torch.dtype
                  ) -> torch.Tensor:
    """(size,) pixel centres of a side in units of its unpadded ``valid`` fraction: the
    anchor prior's coordinates, a constant (callers must not write into it)."""
    with torch.inference_mode(False), torch.no_grad():
        return ((torch.arange(size, device=device) + 0.5) / (size * valid)).to(dtype)


# ----------------------------------------------------------------------------- the head


class SegmentationNet(nn.Module):
    """E_s: image (B, C_in, H, W) -> :class:`SegmentationOutput` with logits/masks (B, n, H, W)."""

    stride = 32  # inputs are padded to a multiple of this internally

    def __init__(
        self,
        in_channels: int = 3,
        num_queries: int = 100,
        backbone: Literal["small", "resnet50"] = "resnet50",
        backbone_channels: tuple[int, ...] = (32, 64, 128, 256),
        backbone_weights: str | None = None,
        conv_dim: int = 256,
        mask_dim: int = 256,
        hidden_dim: int = 256,
        num_heads: int = 8,
        ffn_dim: int = 2048,
        num_layers: int = 4,
        attn_mask_mode: Literal["sigmoid", "softmax"] = "sigmoid",
        mask_pos_scale: float = 0.0,
        anchor_prior: bool = False,
        mask_stride: int = 4,
    ) -> None:
        super().__init__()
        if backbone == "resnet50":
            self.backbone: nn.Module = ResNet50Backbone(in_channels, backbone_weights)
        else:
            self.backbone = SmallBackbone(in_channels, backbone_channels)
        self.pixel_decoder = FPNPixelDecoder(self.backbone.out_channels, conv_dim, mask_dim)
        self.input_proj = nn.ModuleList(
            nn.Identity() if conv_dim == hidden_dim else nn.Conv2d(conv_dim, hidden_dim, 1)
            for _ in range(3)
        )
        self.level_embed = nn.Parameter(torch.zeros(3, hidden_dim))
        self.query_feat = nn.Parameter(torch.randn(num_queries, hidden_dim) * 0.02)
        self.query_pos = nn.Parameter(torch.randn(num_queries, hidden_dim) * 0.02)
        self.layers = nn.ModuleList(
            DecoderLayer(hidden_dim, num_heads, ffn_dim) for _ in range(num_layers)
        )
        self.mask_head = MaskHead(hidden_dim, mask_dim)
        self.num_queries, self.hidden_dim = num_queries, hidden_dim
        self.attn_mask_mode, self.mask_pos_scale = attn_mask_mode, mask_pos_scale
        self.anchor_prior = AnchorPrior(num_queries, hidden_dim) if anchor_prior else None
        self.upsampler = (MaskUpsampler(in_channels, mask_dim, mask_stride)
                          if mask_stride != 4 else None)

    @classmethod
    def from_config(cls, cfg: SegmentationConfig) -> SegmentationNet:
        return cls(**vars(cfg))  # the config's fields are the constructor's arguments

    def blocked_from_logits(self, logits: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
        """Attention mask for the next layer from mask logits (B, n, h, w) -> (B, n, L) bool."""
        with torch.no_grad():  # no gradient through the mask
            logits = bilinear_sample(logits, size)  # F.interpolate, bilinear
            if self.attn_mask_mode == "sigmoid":
                blocked = logits.sigmoid() < 0.5
            else:
                blocked = logits.softmax(dim=1) < 1.0 / logits.shape[1]
        blocked = blocked.flatten(2)  # (B, n, L)
        full = blocked.all(dim=-1, keepdim=True)  # a query blocked everywhere sees everything
        return blocked & ~full

    def _memories(self, levels: list[torch.Tensor]):
        mems, poss, sizes = [], [], []
        for i, x in enumerate(levels):
            h, w = x.shape[-2:]
            pos = sine_position_encoding(h, w, self.hidden_dim, x.device, x.dtype)  # (D, h, w)
            mem = self.input_proj[i](x).flatten(2).transpose(1, 2)  # (B, L, D)
            mems.append(mem + self.level_embed[i])
            poss.append(pos.flatten(1).transpose(0, 1)[None])  # (1, L, D)
            sizes.append((h, w))
        return mems, poss, sizes

    def _coarse_predictor(self, mask_features: torch.Tensor, sizes: list[tuple[int, int]],
                          valid: tuple[float, float]):
        """f(queries (B, n, D), level) -> the stride-4 prediction bilinearly resampled to that
        memory level's size, (B, n, h_l, w_l), without gradient: what the attention mask of
        a layer needs (:meth:`blocked_from_logits`), computed at the level's size. Resampling
        is linear and the anchor prior a sum of a row and a column term (each resampling
        axis's weights sum to 1), so query . resampled features + the resampled terms equal
        the resampled prediction up to float rounding, without the four full-size
        predictions, their prior maps and resampling (1.1x less time for the segmenter
        training step)."""
        feats = [bilinear_sample(mask_features.detach(), size) for size in sizes]
        full = tuple(mask_features.shape[-2:])

        @torch.no_grad()
        def predict(queries: torch.Tensor, lvl: int) -> torch.Tensor:
            logits = self.mask_head(queries, feats[lvl])  # (B, n, h_l, w_l)
            if self.anchor_prior is None:
                return logits
            ty, tx = self.anchor_prior.terms(queries, full, valid)  # (B, n, H'/4), (.., W'/4)
            (hl, wl) = sizes[lvl]
            ty = bilinear_sample(ty[..., None], (hl, 1))[..., 0]  # (B, n, h_l)
            tx = bilinear_sample(tx[..., None, :], (1, wl))[..., 0, :]  # (B, n, w_l)
            return logits - ty[..., :, None] - tx[..., None, :]

        return predict

    def forward(self, image: torch.Tensor, return_attention: bool = False,
                out_size: tuple[int, int] | None = None, aux: bool = False
                ) -> SegmentationOutput:
        """``out_size``: return the logits bilinearly resized from the input size to this size
        (computed directly from stride 4, see :func:`upsample_crop_resize`). ``aux``: also
        the stride-4 predictions of the initial queries and after every layer (deep
        supervision); without it the attention masks come from predictions made directly at
        each memory level's size (:meth:`_coarse_predictor`)."""
        b, _, h, w = image.shape
        x = pad_to_multiple(image, self.stride)  # (B, C_in, H', W')
        mask_features, levels = self.pixel_decoder(self.backbone(x))  # (B, C, H'/4, W'/4)
        if self.mask_pos_scale:
            pos = sine_position_encoding(*mask_features.shape[-2:], mask_features.shape[1],
                                         mask_features.device, mask_features.dtype)
            mask_features = mask_features + self.mask_pos_scale * pos  # weak absolute position
        mems, poss, sizes = self._memories(levels)
        tgt = self.query_feat[None].expand(b, -1, -1)  # (B, n, D)
        qpos = self.query_pos[None].expand(b, -1, -1)
        valid = (h / x.shape[-2], w / x.shape[-1])  # unpadded fraction of the padded input

        def predict(queries: torch.Tensor) -> torch.Tensor:  # (B, n, H'/4, W'/4)
            logits = self.mask_head(queries, mask_features)
            if self.anchor_prior is not None:
                logits = logits + self.anchor_prior(queries, tuple(logits.shape[-2:]), valid)
            return logits

        coarse = None if aux else self._coarse_predictor(mask_features, sizes, valid)
        aux_logits = [predict(tgt)] if aux else []
        attn_masks, attn_weights = [], []
        for i, layer in enumerate(self.layers):
            lvl = i % len(mems)
            prev = aux_logits[-1] if aux else coarse(tgt, lvl)  # the previous prediction
            blocked = self.blocked_from_logits(prev, sizes[lvl])  # (B, n, L)
            tgt, weights = layer(tgt, qpos, mems[lvl], poss[lvl], blocked, return_attention)
            if aux:
                aux_logits.append(predict(tgt))
            if return_attention:
                attn_masks.append(blocked)
                attn_weights.append(weights)
        logits = aux_logits[-1] if aux else predict(tgt)  # (B, n, H'/4, W'/4)
        if self.upsampler is not None:  # the final masks at stride 2 or 1
            fine = self.upsampler(mask_features, x)  # (B, C, H'/s, W'/s)
            # the prior stays a stride-4 map, upsampled: a fresh upsampler then changes nothing
            logits = self.mask_head(tgt, fine) + F.interpolate(
                logits - self.mask_head(tgt, mask_features), size=fine.shape[-2:],
                mode="bilinear", align_corners=False)
        if out_size is None:
            logits = resize(logits, tuple(x.shape[-2:]))[..., :h, :w]  # (B, n, H, W)
        else:
            logits = upsample_crop_resize(logits, tuple(x.shape[-2:]), (h, w), out_size)
        return SegmentationOutput(logits, aux_logits, attn_masks, attn_weights)
