"""Wind deflation (002 §5.2, Eq. 9–12): the long-term average detachment of surface grains by
weak winds from all directions.

A grain leaves the surface when the normal drag F_n exceeds the Mohr–Coulomb threshold
F_n^c = μ_c + μ_f p (Eq. 9), and F_n follows a Rayleigh distribution of scale α (Eq. 11), so
the detachment rate is k_d·P(F_n > F_n^c) (Eq. 10):

    W_d = k_d · exp(−max(F_n^c, 0)² / (2α²))   (Eq. 12, dimensionless as W_a).

Readings of the paper, stated here:
- Eq. 9 writes μ_f·tr(σ). With the Cauchy stress (tension positive) tr σ < 0 under load, which
  would make a compressed grain easier to detach, the opposite of Mohr–Coulomb friction and
  of 002 §3.1 (load protects). Here p = −tr σ, compression positive, the quantity Eq. 2
  compares with I; μ_c and p are stresses (Pa), so α is one too.
- Eq. 12 holds for F_n^c ≥ 0. Where tension makes F_n^c < 0 every drag detaches
  (P(F_n > F_n^c) = 1): W_d = k_d, which the max(·, 0) gives.
- α is not given in 002. Default α = 1 MPa, the cohesion μ_c of Table 2: an unloaded grain
  then deflates at k_d·e^(−1/2) ≈ 0.61 k_d and one under p = 4 MPa (in the range of Table 1's
  interlocking thresholds I) at k_d·e^(−8) ≈ 3e-4 k_d, so deflation, like interlocking,
  spares the loaded parts of the rock.
- 002 Table 1 gives k_d in m⁻²s⁻²; Eq. 12 makes W_d carry k_d's unit and Eq. 1 needs W
  dimensionless (E is in 1/year), so k_d is dimensionless here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DeflationParams:
    """Parameters of deflation (002 Eq. 9–12; Table 2 for μ_c and μ_f).

    Attributes:
        alpha: Rayleigh scale α of the normal drag (Pa); not given in 002 (module docstring).
        cohesion: internal cohesion μ_c (Pa), Table 2: 1 MPa.
        friction: dry friction coefficient μ_f (dimensionless), Table 2: 0.75.
    """

    alpha: float = 1.0e6
    cohesion: float = 1.0e6
    friction: float = 0.75

    def __post_init__(self) -> None:
        if not (math.isfinite(self.alpha) and self.alpha > 0.0):
            raise ValueError(f"the drag scale alpha must be a positive number of Pa, not {self.alpha}")
        if not (math.isfinite(self.cohesion) and self.cohesion >= 0.0):
            raise ValueError(f"the cohesion mu_c must be a finite number ≥ 0 Pa, not {self.cohesion}")
        if not (math.isfinite(self.friction) and self.friction >= 0.0):
            raise ValueError(f"the dry friction mu_f must be a finite number ≥ 0, not {self.friction}")


def detachment_probability(threshold: np.ndarray, alpha: float) -> np.ndarray:
    """P(F_n > threshold) for a Rayleigh-distributed F_n of scale ``alpha`` (002 Eq. 10–11):
    exp(−max(threshold, 0)²/(2α²)); ``threshold`` and ``alpha`` in the same unit (Pa)."""
    t = np.maximum(np.asarray(threshold, dtype=np.float64), 0.0)
    return np.exp(-(t * t) / (2.0 * alpha * alpha))


def deflation_rate(surface: np.ndarray, k_d: np.ndarray, compression: np.ndarray,
                   params: DeflationParams) -> np.ndarray:
    """Wind deflation W_d (002 Eq. 12), ``(N,)``, dimensionless; 0 off the surface.

    Args:
        surface: which particles are on the surface, ``bool (N,)``.
        k_d: deflation coefficient per particle ``(N,)`` (dimensionless, module docstring).
        compression: p = −tr σ per particle ``(N,)`` (Pa, compression positive).
        params: α, μ_c, μ_f.

    Deflation comes from all directions alike (002 §5.2), so it does not depend on the normal.
    """
    index = np.flatnonzero(surface)
    threshold = params.cohesion + params.friction * np.asarray(compression, dtype=np.float64)[index]
    rate = np.zeros(len(surface))
    rate[index] = np.asarray(k_d, dtype=np.float64)[index] * detachment_probability(threshold, params.alpha)
    return rate
