"""The model's one typed configuration: ``configs/model/*.yaml``, the trainer, :func:`build_model`,
the export header and the tests all use :class:`ModelConfig`.

A preset (tiny, small, paper: :class:`neuraltex.networks.NetworksConfig`) fixes the network
sizes; the other fields are the few choices a run makes on top of it and the settings of
estimation (eqs. 4.3-4.7) and splatting (eqs. 4.11-4.14).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any

from neuraltex.limits import MAX_MODEL_SIDE, MAX_TEXTONS

if TYPE_CHECKING:
    from neuraltex.networks import NetworksConfig


@dataclass(frozen=True)
class ModelConfig:
    preset: str = "tiny"  # tiny | small | paper
    num_queries: int | None = None  # n = max textons per image; None: the preset's
    anchor_prior: bool | None = None  # grid-anchored queries; None: the preset's
    mask_stride: int | None = None  # final E_s mask logits at stride 4, 2 or 1; None: 4
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
            raise ValueError(f"unknown model settings: {', '.join(sorted(unknown))[:200]}")
        for name, value in values.items():
            _check(name, value)
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
        if self.mask_stride:
            nets.segmentation.mask_stride = int(self.mask_stride)
        return nets


# name -> (type, low, high, may be None): what a config (or a foreign export header) may hold.
_BOUNDS: dict[str, tuple[type, float, float, bool]] = {
    "num_queries": (int, 1, MAX_TEXTONS, True),
    "image_size": (int, 8, MAX_MODEL_SIDE, True),
    "estimation_size": (int, 8, MAX_MODEL_SIDE, True),
    "eps": (float, 1e-12, 1.0, False),
    "temperature": (float, 1e-3, 1e3, False),
    "cutoff": (float, 0.5, 100.0, True),
}


def _check(name: str, value: Any) -> None:
    """ValueError unless ``value`` is a sane setting ``name`` (types and ranges)."""
    if name == "preset":
        if not isinstance(value, str):
            raise ValueError(f"model setting 'preset' must be a string, got {type(value).__name__}")
        return
    if name == "mask_stride":
        if value is not None and (isinstance(value, bool) or value not in (1, 2, 4)):
            raise ValueError(f"model setting 'mask_stride' must be 1, 2, 4 or null, got "
                             f"{str(value)[:40]}")
        return
    if name == "anchor_prior":
        if value is not None and not isinstance(value, bool):
            raise ValueError("model setting 'anchor_prior' must be true, false or null")
        return
    kind, lo, hi, optional = _BOUNDS[name]
    if value is None and optional:
        return
    ok_type = isinstance(value, (int, float) if kind is float else int)
    if not ok_type or isinstance(value, bool) or not lo <= value <= hi:
        raise ValueError(f"model setting {name!r} must be {kind.__name__} in [{lo:g}, {hi:g}]"
                         f"{' or null' if optional else ''}, got {str(value)[:40]}")
