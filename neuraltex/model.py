"""The Gaussian-texton autoencoder: image -> textons -> image (seed 003, 4.3.1-4.3.4).

    encode:  E_FC(I) -> F_a, V;  E_s(I) -> S;  E_g(S, F_a, V) -> textons
    decode:  h(textons, size) -> F_s, F_max;  G(F_s, F_max) -> image  (+ texton detail)

The networks are injected (:func:`build_model` builds them from a :class:`ModelConfig`); this
module only wires them, and the config holds the estimation/splatting settings. Images are
(B, 3, H, W) in [0, 1]. Textons are resolution independent, so ``decode`` renders any size.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from neuraltex.coords import Window, default_window
from neuraltex.estimation import Existence, estimate_textons
from neuraltex.model_config import ModelConfig
from neuraltex.nn_utils import shrink_short_side
from neuraltex.segmentation import SegmentationNet
from neuraltex.splatting import Splat, splat
from neuraltex.texton_detail import render_detail, split
from neuraltex.textons import Textons


class Encoded(NamedTuple):
    textons: Textons
    masks: Tensor       # (B, n, h, w) softmax over n, at the estimation resolution
    appearance: Tensor  # (B, C, h, w)
    direction: Tensor   # (B, 2, h, w)


class TextonAutoencoder(nn.Module):
    """E = (E_FC, E_s, E_g), h, G wired together.

    ``encoder(image) -> (appearance, direction)``, ``segmenter(image) -> mask logits``
    (B, n, h', w'), ``generator(features, max_opacity) -> image``. ``config`` describes the
    model (and sets estimation and splatting); ``info`` is how it was trained (the export
    header, empty for a fresh model).
    """

    def __init__(self, encoder: nn.Module, segmenter: nn.Module, generator: nn.Module,
                 config: ModelConfig | None = None, info: dict | None = None) -> None:
        super().__init__()
        self.encoder, self.segmenter, self.generator = encoder, segmenter, generator
        self.config = config or ModelConfig()
        self.info = dict(info or {})

    @property
    def estimation_size(self) -> int | None:
        """Resolution at which masks and feature maps meet in E_g (None: the input size)."""
        return self.config.estimation_size

    @property
    def cutoff(self) -> float | None:
        """Mahalanobis cut-off of the splatting."""
        return self.config.cutoff

    @property
    def native_size(self) -> int | None:
        """The training resolution (short side) that :meth:`encode` downscales larger inputs
        to."""
        return self.config.image_size

    def encode(self, image: Tensor, existence: Existence = "round",
               generator: torch.Generator | None = None, native: bool = True) -> Encoded:
        """Image (B, 3, H, W) in [0, 1] -> textons (+ the maps they came from).

        With ``native`` (inference), an image whose short side exceeds the model's training
        resolution ``native_size`` is first downscaled to it, so the networks see textons at
        the scale they were trained on; textons are resolution independent, so nothing else
        changes. The trainer passes ``native=False`` (its crops are already at that scale).
        """
        window = default_window(*image.shape[-2:])  # the input's canvas, kept when resized
        if native and self.native_size:
            image = shrink_short_side(image, self.native_size)
        appearance, direction = self.encoder(image * 2 - 1)
        masks = self.segment(image)
        size = tuple(masks.shape[-2:])
        appearance = _resize(appearance, size)
        direction = _resize(direction, size)
        textons = estimate_textons(masks, appearance, direction, existence=existence,
                                   temperature=self.config.temperature,
                                   eps=self.config.eps,
                                   window=window, generator=generator)
        return Encoded(textons, masks, appearance, direction)

    def segment(self, image: Tensor) -> Tensor:
        """E_s: image (B, 3, H, W) in [0, 1] -> masks S (B, n, h, w), softmax over the n
        queries, at the estimation resolution."""
        return self.segment_logits(image).softmax(dim=1)

    def segment_logits(self, image: Tensor) -> Tensor:
        """E_s before its softmax: image (B, 3, H, W) in [0, 1] -> logits (B, n, h, w) at the
        estimation resolution (a loss on sampled pixels takes the softmax of those only)."""
        size = self._estimation_hw(image)
        if isinstance(self.segmenter, SegmentationNet):
            return self.segmenter(image * 2 - 1, out_size=size).logits
        seg = self.segmenter(image * 2 - 1)
        logits = getattr(seg, "logits", seg)  # (B, n, h', w')
        return F.interpolate(logits, size=size, mode="bilinear", align_corners=False)

    def render(self, textons: Textons, size: tuple[int, int]) -> Splat:
        return splat(textons, size, cutoff=self.cutoff)

    def decode(self, textons: Textons, size: tuple[int, int], *, window: Window | None = None,
               generator: nn.Module | None = None) -> Tensor:
        """Textons -> image (B, 3, H, W) in [0, 1] at ``size`` = (H, W) over ``window`` (the
        canvas by default), with ``generator`` (default: the model's G). Features beyond what
        G takes are texton sprites (:mod:`neuraltex.texton_detail`), added as detail."""
        G = self.generator if generator is None else generator
        plain, sprites = split(textons, G.feature_channels - 2)
        s = splat(plain, size, window=window, cutoff=self.cutoff)
        image = (G(s.features, s.max_opacity) + 1) / 2  # G ends in tanh
        if sprites is None:
            return image
        return (image + render_detail(plain, sprites, size, window, self.cutoff)).clamp(0, 1)

    def reconstruct(self, image: Tensor) -> Tensor:
        return self.decode(self.encode(image).textons, tuple(image.shape[-2:]))

    def _estimation_hw(self, image: Tensor) -> tuple[int, int]:
        H, W = image.shape[-2:]
        if self.estimation_size is None:
            return (H, W)
        s = self.estimation_size / min(H, W)
        return (max(1, round(H * s)), max(1, round(W * s)))


def _resize(x: Tensor, size: tuple[int, int]) -> Tensor:
    if tuple(x.shape[-2:]) == tuple(size):
        return x
    return F.interpolate(x, size=size, mode="bilinear", align_corners=False)


def build_model(config: ModelConfig, with_critics: bool = False, info: dict | None = None):
    """The autoencoder a :class:`ModelConfig` describes (``info``: its training record). With
    ``with_critics`` also returns the image and patch discriminators: (model, D, D_p)."""
    from neuraltex.networks import build_networks

    nets = build_networks(config.networks())
    model = TextonAutoencoder(nets.encoder, nets.segmentation, nets.generator, config, info)
    if not with_critics:
        return model
    return model, nets.discriminator, nets.patch_discriminator


DEFAULT_MODEL = Path(__file__).resolve().parent / "weights" / "default.safetensors"


def load_model(path, device: str | torch.device = "cpu",
               num_queries: int | None = None) -> TextonAutoencoder:
    """Load an inference export (``.safetensors``) for encode/decode; errors are one line.
    ``num_queries``: with E_s's queries resampled to this many (:mod:`neuraltex.query_grid`)."""
    from neuraltex.checkpoint import CheckpointError, load_exported_model
    from neuraltex.fit_prior import attach_prior

    state, config, info = load_exported_model(path)
    try:
        cfg = ModelConfig.from_dict(config)
        if num_queries:
            from neuraltex.query_grid import resampled

            cfg, state = resampled(cfg, state, num_queries)
        model = build_model(cfg, info=info)
        model.load_state_dict(state)
    except (KeyError, ValueError, RuntimeError, TypeError) as exc:
        raise CheckpointError(f"{path}: weights do not fit the model they describe "
                              f"({' '.join(str(exc).split())[:160]})") from None
    attach_prior(model, path)
    return model.to(device).eval()
