"""The model's one typed configuration: ``configs/model/*.yaml``, the trainer, :func:`build_model`,
the export header and the tests all use :class:`ModelConfig`.

A preset (tiny, small, paper: :class:`neuraltex.networks.NetworksConfig`) fixes the network
sizes; the other fields are the few choices a run makes on top of it and the settings of
estimation (eqs. 4.3-4.7) and splatting (eqs. 4.11-4.14).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from neuraltex.networks import NetworksConfig


@dataclass(frozen=True)
class ModelConfig:
    preset: str = "tiny"  # tiny | small | paper
    num_queries: int | None = None  # n = max textons per image; None: the preset's
    anchor_prior: bool | None = None  # grid-anchored queries; None: the preset's
    image_size: int | None = None  # training resolution (short side); None: any
    estimation_size: int | None = None  # where masks meet features in E_g; None: input size
    eps: float = 1e-5  # covariance regularizer of eq. 4.4
    temperature: float = 1.0  # Gumbel-softmax temperature of the existence sampling (eq. 4.5)
    cutoff: float | None = None  # Mahalanobis cut-off of the splatting (the release uses 3)

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> ModelConfig:
        """From ``cfg.model`` or an export header; unknown keys are an error, missing ones
        take the defaults."""
        names = {f.name for f in fields(cls)}
        unknown = set(values) - names
        if unknown:
            raise ValueError(f"unknown model settings: {', '.join(sorted(unknown))}")
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def networks(self) -> NetworksConfig:
        """The preset's network sizes with this config's overrides."""
        from neuraltex.networks import NetworksConfig

        nets = NetworksConfig.preset(self.preset)
        if self.num_queries:
            nets.segmentation.num_queries = int(self.num_queries)
        if self.anchor_prior is not None:
            nets.segmentation.anchor_prior = bool(self.anchor_prior)
        return nets
