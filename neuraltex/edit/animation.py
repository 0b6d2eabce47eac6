"""Texture animation by flow fields moving textons (seed 003, 4.4.6, appendix 7.7.3).

Positions are mapped to [-1, 1]^2 over the canvas as in the appendix:

- perturbed shear flow (eq. 7.1): rows above y = -1/3 move left, rows below y = 1/3 move
  right with speed v, each shifted by a perturbation eps_t (10 key frames ~ N(0, 1/30),
  interpolated in time, eps_0 = 0); the middle band stays; y is unchanged;
- vortex flow (eq. 7.2): the polar angle grows by omega t around the centre, radius fixed;
  textons turn with the flow (their covariance and direction rotate by the same angle).

Positions wrap around the borders. Frame 0 is the input; a vortex returns to it after one
period 2 pi / omega.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import torch

from neuraltex.textons import Textons


def _to_unit(t: Textons) -> tuple[torch.Tensor, torch.Tensor]:
    w, h = t.canvas
    return t.mu[..., 0] / w * 2 - 1, t.mu[..., 1] / h * 2 - 1


def _from_unit(t: Textons, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    w, h = t.canvas
    x = torch.remainder(x + 1, 2) - 1  # wrap around
    y = torch.remainder(y + 1, 2) - 1
    return torch.stack([(x + 1) / 2 * w, (y + 1) / 2 * h], dim=-1)


def shear_perturbation(duration: float, seed: int = 0, keys: int = 10,
                       std: float = 1 / 30):
    """eps(t) for t in [0, duration]: linear interpolation of ``keys`` normal samples."""
    rng = np.random.default_rng(seed)
    times = np.linspace(0.0, duration, keys)
    values = rng.normal(0.0, std, keys)
    values[0] = 0.0
    return lambda t: float(np.interp(t, times, values))


def shear_flow(textons: Textons, t: float, velocity: float = 0.5, eps: float = 0.0) -> Textons:
    """eq. 7.1 at time t (in units where the canvas spans 2)."""
    x, y = _to_unit(textons)
    shift = torch.where(y < -1 / 3, -velocity * t + eps,
                        torch.where(y > 1 / 3, velocity * t + eps, torch.zeros_like(x)))
    return replace(textons, mu=_from_unit(textons, x + shift, y))


def vortex_flow(textons: Textons, t: float, omega: float = 2 * math.pi / 4) -> Textons:
    """eq. 7.2 at time t: rotate about the canvas centre by omega t (counter-clockwise on
    screen for omega > 0), positions wrapped into the canvas."""
    w, h = textons.canvas
    turned = textons.rotate(math.degrees(omega * t), center=(w / 2, h / 2))
    x, y = _to_unit(turned)
    return replace(turned, mu=_from_unit(turned, x, y))


def animate(textons: Textons, flow: str, frames: int, duration: float = 4.0, seed: int = 0,
            velocity: float = 0.5, omega: float = 2 * math.pi / 4) -> list[Textons]:
    """Texton sets for ``frames`` evenly spaced times in [0, duration)."""
    eps = shear_perturbation(duration, seed)
    out = []
    for i in range(frames):
        t = duration * i / frames
        if flow == "shear":
            out.append(shear_flow(textons, t, velocity, eps(t)))
        elif flow == "vortex":
            out.append(vortex_flow(textons, t, omega))
        else:
            raise ValueError(f"unknown flow {flow!r} (shear or vortex)")
    return out

