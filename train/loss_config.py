"""The loss configuration (``configs/loss/*.yaml``) as one typed value, and what it says at a
step (eq. 4.24, appendix 7.7.2).

:class:`LossConfig` is the only way loss settings reach :mod:`train.objective`; the trainer
turns it into a :class:`StepSettings` per step (scheduled weights, patch size, warm-ups).
Defaults are the paper's (``configs/loss/default.yaml`` holds the same values).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any

from train.consistency import ConsistencyWeights
from train.schedule import Schedule, scheduled

WEIGHTS = ("entropy", "compact", "csis", "texture", "gan", "pgan", "mask")


@dataclass(frozen=True)
class StepSettings:
    """The loss settings in force at one step."""

    entropy: float  # lambda_e
    compact: float  # lambda_c
    csis: float  # lambda_csis
    texture: float  # lambda_t (sliced Wasserstein of reshuffled patches)
    gan: float  # lambda_adv, image GAN
    pgan: float  # lambda_adv, patch GAN
    mask: float  # optional mask supervision
    patch_size: int  # patch side of the texture loss
    existence: str = "sample"  # "all" during loss.existence_warmup (every delta = 1)
    segmenter_only: bool = False  # loss.segmenter_warmup: only E_s learns the given masks
    diagnostics: bool = True  # all diag/* numbers (the trainer: only on steps it logs)
    # Lazy terms: the weight of the reshuffle terms (texture, patch GAN, D_p) and of the
    # equivariance terms (csis, L'_R) at this step: every k-th step k, else 0 (not computed)
    reshuffle: float = 1.0
    equivariance: float = 1.0

    def scalars(self) -> dict[str, float]:
        """The weights and the patch size, for the log (``w/<name>``)."""
        return {k: float(getattr(self, k)) for k in (*WEIGHTS, "patch_size")}


@dataclass(frozen=True)
class LossConfig:
    w_l1: float = 2.0
    w_lpips: float = 0.2
    lpips_backbone: str = "auto"  # auto | pretrained | random
    w_entropy: Schedule = ((0, 0.08), (100000, 0.1))
    w_compact: Schedule = ((0, 100.0), (1000, 1.0), (5000, 0.2))
    w_csis: Schedule = ((0, 0.008), (5000, 0.08))
    w_texture: Schedule = ((0, 0.01),)
    w_gan: Schedule = ((0, 0.1),)
    w_pgan: Schedule = ((0, 0.1),)
    w_mask: Schedule = ((0, 1.0),)
    patch_size: Schedule = ((0, 2), (40000, 4), (80000, 6))
    reshuffle_gamma: float = 0.5
    r1_every: int = 16
    r1_gamma_d: float = 10.0
    r1_gamma_dp: float = 0.1
    existence_warmup: int = 0  # paper steps (x schedule scale) with delta = 1 for all textons
    segmenter_warmup: int = 0  # paper steps (x schedule scale) training only E_s
    mask_supervision: str = "none"  # none | gt | pseudo
    mask_points: int | None = None  # pixels per image the mask loss samples; None: all
    equivariance: bool = True
    reshuffle: bool = True
    # Lazy terms (as lazy R1, StyleGAN2): computed on every k-th step only, weighted by k, so
    # the expected loss is unchanged and a step skips a decode (and an encode) most of the time
    equivariance_every: int = 1
    reshuffle_every: int = 1
    gan: bool = True
    csis_reduce: str = "sum"  # sum (eq. 4.22) | mean over matched pairs
    csis_lambda: ConsistencyWeights = field(default_factory=ConsistencyWeights)

    def __post_init__(self) -> None:
        if self.mask_supervision not in ("none", "gt", "pseudo"):
            raise ValueError(f"loss.mask_supervision must be none, gt or pseudo, "
                             f"got {self.mask_supervision!r}")
        for name in ("equivariance_every", "reshuffle_every", "r1_every"):
            if int(getattr(self, name)) < (0 if name == "r1_every" else 1):
                raise ValueError(f"loss.{name} must be a positive whole number of steps, "
                                 f"got {getattr(self, name)!r}")
        if self.csis_reduce not in ("sum", "mean"):
            raise ValueError(f"loss.csis_reduce must be sum or mean, got {self.csis_reduce!r}")

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> LossConfig:
        """From a resolved ``cfg.loss``; unknown keys are an error."""
        names = {f.name for f in fields(cls)}
        unknown = set(values) - names
        if unknown:
            raise ValueError(f"unknown loss settings: {', '.join(sorted(unknown))}")
        values = {k: tuple(map(tuple, v)) if isinstance(v, list) else v  # [[step, value]]
                  for k, v in values.items()}
        if isinstance(values.get("csis_lambda"), dict):
            values["csis_lambda"] = ConsistencyWeights(**values["csis_lambda"])
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def at(self, step: int, scale: float = 1.0) -> StepSettings:
        """The settings at ``step``; milestones and warm-ups are paper steps x ``scale``."""
        return StepSettings(
            **{k: scheduled(getattr(self, f"w_{k}"), step, scale) for k in WEIGHTS},
            patch_size=int(scheduled(self.patch_size, step, scale)),
            existence="all" if step < self.existence_warmup * scale else "sample",
            segmenter_only=step < self.segmenter_warmup * scale,
            reshuffle=_lazy(self.reshuffle_every, step),
            equivariance=_lazy(self.equivariance_every, step),
        )


def _lazy(every: int, step: int) -> float:
    """The weight of a term computed every ``every`` steps: ``every`` on the steps that end
    a period (so a run's logged steps, multiples of its log interval, carry it), else 0."""
    return float(every) if (step + 1) % every == 0 else 0.0
