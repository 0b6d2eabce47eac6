"""The decoder of a tuned texture: G plus a splatted colour offset per texton.

A texture tuned by :mod:`neuraltex.fit` gives every texton, beside its appearance feature f
(C_a channels, unit length, eq. 4.6), a colour offset d (3 channels, RGB in [-1, 1] units).
Both are appearance: they are splatted together (eqs. 4.11-4.14), move with the texton in
every edit, and are traded together by reshuffle and transfer. The decoder adds the
composited offsets to G's output, so a texton's colour is right from the first tuning step
and G only has to learn the detail; a pixel that no texton covers gets no offset.

Texton layout: f = [f_a (C_a), d (3)], followed by the texton's detail sprite vec(D) (3 S^2)
when it has one (:mod:`neuraltex.texton_detail`; the decoder renders it after G); splatted
features F_s = [f_a, d, v] (B, C_a + 5, H, W).
"""

from __future__ import annotations

import copy

import torch
from torch import Tensor, nn

from neuraltex.textons import Textons

COLOUR = 3  # channels of the colour offset d


class ColourOffsetGenerator(nn.Module):
    """(F_s (B, C_a + 5, H, W), F_max (B, 1, H, W)) -> image in [-1, 1]: G on [f_a, v] plus
    twice the composited offsets d (G's range is twice the [0, 1] image range)."""

    def __init__(self, generator: nn.Module) -> None:
        super().__init__()
        self.generator = generator
        self.appearance_channels = generator.feature_channels - 2
        self.feature_channels = generator.feature_channels + COLOUR

    def forward(self, features: Tensor, max_opacity: Tensor) -> Tensor:
        c = self.appearance_channels
        plain = torch.cat([features[:, :c], features[:, c + COLOUR:]], dim=1)  # (B, C_a+2, H, W)
        offset = features[:, c:c + COLOUR]  # (B, 3, H, W)
        return (self.generator(plain, max_opacity) + 2 * offset).clamp(-1, 1)


def tuned_model(model, generator: dict[str, Tensor]):
    """A copy of ``model`` whose decoder is the tuned G (parameters by name) plus offsets."""
    tuned = copy.deepcopy(model)
    with torch.no_grad():
        for name, p in tuned.generator.named_parameters():
            p.copy_(generator[name].to(p))
    tuned.generator = ColourOffsetGenerator(tuned.generator)
    return tuned.eval()


def blended_model(a, b, t: float):
    """The tuned model ``a`` with G's parameters blended towards ``b``'s: (1 - t) a + t b
    (both tuned from the same base, so their weights interpolate)."""
    out = copy.deepcopy(a)
    with torch.no_grad():
        for (_, p), (_, q) in zip(out.generator.named_parameters(),
                                  b.generator.named_parameters(), strict=True):
            p.lerp_(q.to(p), t)
    return out


def with_offsets(textons: Textons) -> Textons:
    """Textons of the base model (f: C_a channels) -> the tuned layout [f_a, d] with d = 0
    (the texton keeps the colour G gives it)."""
    from dataclasses import replace

    return replace(textons, f=torch.cat([textons.f, textons.f.new_zeros(
        *textons.f.shape[:2], COLOUR)], dim=-1))


def combine(model, items: list[tuple[Textons, object]], t: float | None = None):
    """The model that decodes a combination of textures and their textons in its layout.

    ``items``: (textons, tuned model or None) per texture, in priority order. Without tuned
    ones: ``model`` and the textons as they are. Otherwise the first tuned decoder (with
    ``t``, the first two blended in weight space, (1 - t) G_a + t G_b, as they share the base),
    and every set brought to one layout: plain textures get zero colour offsets
    (:func:`with_offsets`), and when any texture has detail sprites, every set gets sprites of
    the largest side (resampled, or blank for textures without them).
    Returns (decoder model, [textons]).
    """
    from neuraltex.texton_detail import resize_sprites, sprite_side

    tuned = [dec for _, dec in items if dec is not None]
    if not tuned:
        return model, [textons for textons, _ in items]
    decoder = tuned[0]
    if t is not None and len(tuned) > 1:
        decoder = blended_model(tuned[0], tuned[1], t)
    base = decoder.generator.feature_channels - 2  # [f_a, d]
    sets = [with_offsets(textons) if dec is None else textons for textons, dec in items]
    sides = [sprite_side(s.feature_dim - base) for s in sets]
    if not any(sides):
        return decoder, sets
    side = max(s for s in sides if s)
    return decoder, [resize_sprites(s, base, side) for s in sets]
