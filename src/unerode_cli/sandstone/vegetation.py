"""Vegetation (002 §8.3, Fig. 11): plants shield the rock from wind and water, and grow on deposits.

002 lets the user paint a vegetation cover that "adjust[s] the erodibility and provide[s] a
shielding effect" and shows "new plants grow[ing] at the deposit areas at the foot of the hill",
but gives no equation and no number. Here:

- Shielding: a particle of cover v ∈ [0, 1] erodes at (1 − s·v) times its bare rate, wind
  (abrasion Eq. 8 + deflation Eq. 12) and fluvial (Eq. 14) alike: b −= E·(1 − s·v)·(W + F)·Δt
  in Eq. 1. The shielding factor s ∈ [0, 1] (dimensionless) is this project's choice, default
  :data:`DEFAULT_SHIELD` = 0.9: a full cover keeps a tenth of the bare erosion, so vegetated
  ground still wears (s = 1 would make it non-erodible, like the erodibility paint 0).
- Growth: a deposit particle (002 §7) on the surface that was not eroded during a frame gains
  cover R·Δt, up to 1 (R in cover per year). Plants need a surface to root in: a buried deposit
  does not grow any, and neither does the rock (002 §8.3: new plants grow on the deposits).
  R = 0 (the default) keeps the painted cover as it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Share of the erosion a full cover (v = 1) takes away (002 gives no number).
DEFAULT_SHIELD = 0.9


@dataclass(frozen=True)
class VegetationParams:
    """``shield`` s, the share of erosion a full cover removes (dimensionless, in [0, 1]);
    ``growth`` R, the cover stable surface deposits gain per year (1/y, ≥ 0)."""

    shield: float = DEFAULT_SHIELD
    growth: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.shield <= 1.0:
            raise ValueError(f"the vegetation shield must lie in [0, 1], not {self.shield}")
        if not (math.isfinite(self.growth) and self.growth >= 0.0):
            raise ValueError(f"the vegetation growth must be a finite cover per year ≥ 0, not {self.growth}")


def shielding(cover: np.ndarray, shield: float) -> np.ndarray:
    """The factor 1 − s·v (dimensionless, in [1 − s, 1]) on the erosion rates of particles of
    vegetation ``cover`` v ∈ [0, 1], for a shielding factor ``shield`` s."""
    return 1.0 - shield * np.asarray(cover, dtype=np.float64)


def grow(cover: np.ndarray, stable: np.ndarray, growth: float, dt: float) -> np.ndarray:
    """The cover after a frame of ``dt`` years: min(1, v + R·Δt) where ``stable`` (the surface
    deposits that were not eroded this frame), unchanged elsewhere; ``growth`` R in 1/y."""
    cover = np.asarray(cover, dtype=np.float64)
    return np.where(stable, np.minimum(1.0, cover + growth * dt), cover)
