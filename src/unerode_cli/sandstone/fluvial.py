"""Fluvial erosion of the sandstone's surface particles by the shear stress of water (002 §6.1,
Eq. 13–14):

    F = k_t (τ − τ_c)₊,   τ = k_f Q^0.6 S^0.7   (Eq. 14, Howard 1994),

with Q the discharge of the particle's cell (``discharge``) and S the slope of the surface
from the particle's normal n (002 §6.2): S = sqrt(n_x² + n_y²)/|n_z|.

Units. Eq. 1 needs F dimensionless (E is in 1/y), so with τ and τ_c in Pa, k_t is in 1/Pa,
as 002 Table 1 gives it (1e2–8e2 Pa⁻¹); it is used as printed. τ is a shear stress in Pa for
Q in m³/s, the mean discharge (Q in m³/y ÷ ``SECONDS_PER_YEAR``): the exponents are those of
a wide channel under Manning's law, τ = ρ_w g R S with a flow depth R = (n q / S^0.5)^0.6 for
a discharge q per unit width, i.e. τ = ρ_w g (n q)^0.6 S^0.7, so

    k_f = ρ_w g (n / w)^0.6 ≈ 1.2e3 Pa (s/m³)^0.6

for water (ρ_w = 1000 kg/m³, g = 9.81 m/s²), Manning's n = 0.03 s/m^⅓ (a bare rock channel)
and a flow ``FLOW_WIDTH`` = 1 m wide. 002 Table 2 prints k_f = 8e-5 "Pa m⁻³ s⁻¹": that unit does
not make τ a stress with Q^0.6, and with the discharge of any rain in m³/s (a 1000 m² catchment
under 0.25 m/y gives 8e-6 m³/s) it would give τ ≈ 1e-7 Pa, never above Table 1's τ_c of 1–5
Pa. With the k_f above, that catchment gives τ ≈ 1 Pa on a 45° slope: Table 1's thresholds
then separate the rock that water erodes (gullies, the foot of falls, the course of a source)
from the rock it leaves, as 002 §8.2 describes. A frame erodes a wet particle at most (b ≤ 0
removes it), so Table 1's k_t, which make F·E·Δt ≥ 1 for an excess of 0.01–0.1 Pa, cut a
channel by about one particle per frame where τ exceeds τ_c.

Slope cap: on a vertical wall n_z = 0 and S is infinite; S is capped at ``max_slope``
(default ``MAX_SLOPE`` = 10, a face at 84°), so a wall particle in a wet cell (the lip of a
fall) erodes as on a slope of 84°.

Only surface particles erode (002 §6), and only where some water flows (Q > 0): F = 0 in dry
cells whatever τ_c.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from unerode_cli.sandstone.layers import GRAVITY

if TYPE_CHECKING:  # numba's import would slow the command line's help, which reads the defaults
    from unerode_cli.sandstone.grid3d import Grid3D

#: Seconds in a (Julian) year: Q in m³/y ÷ this = Q in m³/s.
SECONDS_PER_YEAR = 365.25 * 86400.0
#: Density of water (kg/m³), Manning's roughness of a bare rock channel (s/m^⅓), and the width
#: (m) of the flow in the shear stress.
WATER_DENSITY = 1000.0
MANNING_N = 0.03
FLOW_WIDTH = 1.0
#: Default k_f (Pa (s/m³)^0.6), module docstring.
K_F = WATER_DENSITY * GRAVITY * (MANNING_N / FLOW_WIDTH) ** 0.6
#: Default cap of the slope S (dimensionless), module docstring.
MAX_SLOPE = 10.0
#: Default precipitation (m/y): an arid climate, as on the Colorado Plateau (0.2–0.3 m/y).
PRECIPITATION = 0.25


@dataclass(frozen=True)
class FluvialParams:
    """Parameters of the water and its shear stress (002 §6; the per-layer k_t and τ_c are
    ``Layer`` fields).

    Attributes:
        k_f: discharge multiplier k_f of Eq. 14, Pa (s/m³)^0.6 (module docstring).
        precipitation: p (m/y) falling on the top of the domain.
        sources: point sources, each (x, y, z) (m) and its discharge Q (m³/y).
        max_slope: cap of the slope S (dimensionless), module docstring.
    """

    k_f: float = K_F
    precipitation: float = PRECIPITATION
    sources: tuple[tuple[float, float, float, float], ...] = ()
    max_slope: float = MAX_SLOPE

    def __post_init__(self) -> None:
        if not (math.isfinite(self.k_f) and self.k_f >= 0.0):
            raise ValueError(f"k_f must be a finite number ≥ 0 Pa (s/m³)^0.6, not {self.k_f}")
        if not (math.isfinite(self.precipitation) and self.precipitation >= 0.0):
            raise ValueError(f"the precipitation must be a finite number ≥ 0 m/y, not {self.precipitation}")
        if not (math.isfinite(self.max_slope) and self.max_slope > 0.0):
            raise ValueError(f"the slope cap must be a positive number, not {self.max_slope}")
        for source in self.sources:
            if len(source) != 4 or not all(math.isfinite(v) for v in source):
                raise ValueError(f"a water source is x, y, z (m) and Q (m³/y), all finite, not {source}")
            if source[3] < 0.0:
                raise ValueError(f"a water source's discharge must be ≥ 0 m³/y, not {source[3]:g}")


def slope(normals: np.ndarray, max_slope: float = MAX_SLOPE) -> np.ndarray:
    """S = sqrt(n_x² + n_y²)/|n_z| (002 §6.2) of unit normals ``(N, 3)``, capped at
    ``max_slope`` (module docstring), ``(N,)``."""
    normals = np.asarray(normals, dtype=np.float64)
    across = np.hypot(normals[:, 0], normals[:, 1])
    up = np.abs(normals[:, 2])
    return np.where(across >= max_slope * up, max_slope, across / np.where(up > 0.0, up, 1.0))


def shear_stress(discharge: np.ndarray, slopes: np.ndarray, k_f: float = K_F) -> np.ndarray:
    """τ = k_f Q^0.6 S^0.7 (Pa; 002 Eq. 14) for ``discharge`` Q in m³/y (converted to m³/s,
    module docstring) and dimensionless ``slopes`` S."""
    q = np.asarray(discharge, dtype=np.float64) / SECONDS_PER_YEAR
    return k_f * q**0.6 * np.asarray(slopes, dtype=np.float64) ** 0.7


def fluvial_rate(positions: np.ndarray, normals: np.ndarray, surface: np.ndarray, layer: np.ndarray,
                 k_t: np.ndarray, tau_c: np.ndarray, discharge: np.ndarray, grid: Grid3D,
                 params: FluvialParams) -> np.ndarray:
    """F = k_t (k_f Q^0.6 S^0.7 − τ_c)₊ (002 Eq. 14) of every particle, dimensionless; 0 off
    the surface and in dry cells.

    Args:
        positions: particle positions ``(N, 3)`` (m).
        normals: unit outward normals ``(N, 3)`` (``surface.normals``).
        surface: which particles are on the surface, ``bool (N,)``.
        layer: each particle's layer index ``(N,)``.
        k_t: k_t of each layer (1/Pa), indexed by ``layer``.
        tau_c: τ_c of each layer (Pa), indexed by ``layer``.
        discharge: Q of each cell of ``grid`` (m³/y), ``(nx, ny, nz)`` (``Discharge.q``).
        grid: the grid of ``discharge``.
        params: k_f and the slope cap.
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    which = np.flatnonzero(surface)
    which = which[np.asarray(k_t)[np.asarray(layer)[which]] > 0.0]
    out = np.zeros(positions.shape[0])
    if which.size == 0:
        return out
    cells = np.clip(grid.cells_of(positions[which]), 0, np.asarray(grid.shape) - 1)
    q = np.asarray(discharge)[cells[:, 0], cells[:, 1], cells[:, 2]]
    wet = q > 0.0
    which, q = which[wet], q[wet]
    tau = shear_stress(q, slope(np.asarray(normals)[which], params.max_slope), params.k_f)
    index = np.asarray(layer)[which]
    out[which] = np.asarray(k_t, dtype=np.float64)[index] * np.maximum(
        tau - np.asarray(tau_c, dtype=np.float64)[index], 0.0)
    return out
