"""Surface mass balance of glaciers (001 Eq. 2).

    M = min(p_max, β·(s − E))                                                 (001 Eq. 2)

M: rate of ice thickness gained (> 0, accumulation) or lost (< 0, ablation) at the surface,
in m/y of ice; s: ice surface elevation (m); E: equilibrium-line altitude (m); β: mass-balance
gradient (1/y); p_max: maximum accumulation rate (m/y).
"""

from __future__ import annotations

import numpy as np

from unerode_cli.processes.parameters import ParamSpec

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("beta", "1/y", 1.0e-2, "mass-balance gradient β (001 Eq. 2; 001 Table 1: 0.01 1/y)",
              minimum=0.0, raster=True, symbol="β"),
    ParamSpec("p_max", "m/y", 2.0, "maximum accumulation rate p_max, m/y of ice (001 Eq. 2; "
              "001 Table 1: 2 m/y)", minimum=0.0, raster=True),
    ParamSpec("ela", "m", 1500.0, "equilibrium-line altitude E (001 Eq. 2; 001 Table 1: 500-2000 m)",
              raster=True, symbol="E"),
)


def mass_balance(
    surface: np.ndarray,
    ela: float | np.ndarray,
    beta: float | np.ndarray = 1.0e-2,
    p_max: float | np.ndarray = 2.0,
) -> np.ndarray:
    """Mass balance M = min(p_max, β·(s − E)) (001 Eq. 2), in m/y of ice.

    Args:
        surface: float[ny, nx] ice surface elevation s = b + H (m); the bedrock where there is
            no ice.
        ela: equilibrium-line altitude E (m), scalar or float[ny, nx].
        beta: mass-balance gradient β (1/y), scalar or raster, ≥ 0.
        p_max: maximum accumulation rate p_max (m/y), scalar or raster, ≥ 0.

    Returns:
        float64[ny, nx] M (m/y): positive above E (capped at p_max), negative below.

    Raises:
        ValueError: a raster of another shape than ``surface``, or β or p_max negative.
    """
    s = np.asarray(surface, dtype=np.float64)
    for name, value in (("ela", ela), ("beta", beta), ("p_max", p_max)):
        if np.ndim(value) and np.shape(value) != s.shape:
            raise ValueError(f"{name} has shape {np.shape(value)}, the surface has {s.shape}")
    if np.any(np.asarray(beta) < 0) or np.any(np.asarray(p_max) < 0):
        raise ValueError("beta and p_max must be ≥ 0")
    return np.minimum(p_max, np.asarray(beta) * (s - np.asarray(ela)))
