"""All networks of the texton autoencoder, built together from one preset (tiny, small, paper).

Only shapes connect them: E_FC gives F_a (B, C_a, H, W) and V (B, 2, H, W); E_s gives
S (B, n, H, W); estimation + splatting (elsewhere) turn those into F_s (B, C_a+2, H', W') and
F_max (B, 1, H', W') that G decodes; D and D_p judge images and crops.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from torch import nn

from neuraltex.discriminators import (
    DiscriminatorConfig,
    ImageDiscriminator,
    PatchDiscriminator,
    PatchDiscriminatorConfig,
)
from neuraltex.encoder import EncoderConfig, FCEncoder
from neuraltex.generator import GeneratorConfig, SPADEGenerator
from neuraltex.nn_utils import count_parameters
from neuraltex.segmentation import SegmentationConfig, SegmentationNet

PRESETS = ("tiny", "small", "paper")


@dataclass
class NetworksConfig:
    encoder: EncoderConfig = field(default_factory=EncoderConfig)
    segmentation: SegmentationConfig = field(default_factory=SegmentationConfig)
    generator: GeneratorConfig = field(default_factory=GeneratorConfig)
    discriminator: DiscriminatorConfig = field(default_factory=DiscriminatorConfig)
    patch_discriminator: PatchDiscriminatorConfig = field(default_factory=PatchDiscriminatorConfig)

    def __post_init__(self) -> None:
        want = self.encoder.appearance_channels + 2  # F_s = concat(f_i, v_i), eq. 4.14
        if self.generator.feature_channels != want:
            raise ValueError(f"generator.feature_channels must be C_a + 2 = {want}, "
                             f"got {self.generator.feature_channels}")

    @classmethod
    def preset(cls, name: str) -> NetworksConfig:
        if name not in PRESETS:
            raise ValueError(f"unknown preset {name!r}; choose from {PRESETS}")
        return cls(
            EncoderConfig.preset(name),
            SegmentationConfig.preset(name),
            GeneratorConfig.preset(name),
            DiscriminatorConfig.preset(name),
            PatchDiscriminatorConfig.preset(name),
        )


class Networks(nn.Module):
    """Container for E_FC, E_s, G, D and D_p (one ``state_dict``, one ``.to(device)``)."""

    def __init__(self, encoder: FCEncoder, segmentation: SegmentationNet,
                 generator: SPADEGenerator, discriminator: ImageDiscriminator,
                 patch_discriminator: PatchDiscriminator) -> None:
        super().__init__()
        self.encoder, self.segmentation, self.generator = encoder, segmentation, generator
        self.discriminator, self.patch_discriminator = discriminator, patch_discriminator

    def parameter_counts(self) -> dict[str, int]:
        counts = {name: count_parameters(m) for name, m in self.named_children()}
        counts["total"] = sum(counts.values())
        return counts


def build_networks(config: NetworksConfig | str = "tiny") -> Networks:
    """Build every network from a :class:`NetworksConfig` or a preset name."""
    cfg = NetworksConfig.preset(config) if isinstance(config, str) else config
    return Networks(
        FCEncoder.from_config(cfg.encoder),
        SegmentationNet.from_config(cfg.segmentation),
        SPADEGenerator.from_config(cfg.generator),
        ImageDiscriminator.from_config(cfg.discriminator),
        PatchDiscriminator.from_config(cfg.patch_discriminator),
    )
