"""The classic thermal-erosion cellular automaton (Musgrave, Kolb & Mace 1989), kept to compare
with the flow-following thermal model of 000 §4 (000 Fig. 3).

Each cell hands material to the neighbours it overhangs by more than the talus height
tan θ·distance. To share K_th (m/ky, see ``thermal``) and θ with ``thermal``, one step of dt
years moves dt·k/Δx times the largest excess height difference, with k = K_th/1000 (m/y) and
Δx = min(dx, dy): on a uniform slope S > tan θ that is dt·k·(S − tan θ) metres, the lowering of
000 Eq. 14. The automaton is stable while that fraction is ≤ 1/2, i.e. |dt| ≤ Δx / (2·k). It has
no backward form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.processes.budget import MassBudget, SurfaceChange
from unerode_cli.processes.parameters import ParamSpec, check_fields
from unerode_cli.processes.thermal import K_TH, TALUS_ANGLE, per_year

PARAMETERS: tuple[ParamSpec, ...] = (K_TH, TALUS_ANGLE)

BACKWARD_REFUSAL = ("the thermal cellular automaton (thermal-ca) has no backward form: it "
                    "forgets where its material came from; unerode with --process thermal.")

#: Largest fraction of the excess height moved per step (stability of the automaton).
MAX_FRACTION = 0.5


@dataclass(frozen=True)
class ThermalCAParams:
    """K_th (m/ky, scalar or float[ny, nx]) and the talus angle θ (degrees)."""

    k_th: float | np.ndarray = K_TH.default
    talus_angle: float = TALUS_ANGLE.default

    def validate(self, grid: Grid) -> None:
        check_fields(self, PARAMETERS, grid)


def max_stable_dt(grid: Grid, params: ThermalCAParams) -> float:
    """Largest |dt| (y) with a moved fraction ≤ 1/2: Δx / (2·max K_th/1000) (K_th in m/ky);
    ``inf`` for K_th = 0."""
    k_max = float(per_year(np.max(np.asarray(params.k_th)[grid.valid] if np.ndim(params.k_th)
                                  else params.k_th)))
    return float("inf") if k_max == 0.0 else MAX_FRACTION * min(grid.dx, grid.dy) / k_max


def step(elevation: np.ndarray, grid: Grid, fixed: np.ndarray, params: ThermalCAParams,
         dt: float) -> SurfaceChange:
    """One automaton step of ``dt`` years (> 0, within ``max_stable_dt``).

    Args:
        elevation: float64[ny, nx] (m); not modified.
        fixed: bool[ny, nx] cells that keep their elevation (outlets): what they receive
            leaves the domain.

    Returns:
        Δh (m) and the budget: eroded = deposited + outflux exactly (up to rounding).
    """
    from unerode_cli.processes import thermal_kernels as tk

    params.validate(grid)
    if dt <= 0:
        raise ValueError(BACKWARD_REFUSAL)
    if dt > max_stable_dt(grid, params) * (1.0 + 1e-12):
        raise ValueError(f"thermal-ca step of {dt:g} years is above its stable limit "
                         f"{max_stable_dt(grid, params):.4g} years")
    k = per_year(np.asarray(params.k_th, dtype=np.float64))
    fraction = np.ascontiguousarray(dt * k / min(grid.dx, grid.dy)).ravel()
    h = np.ascontiguousarray(elevation, dtype=np.float64)
    fixed = np.ascontiguousarray(fixed & grid.valid)
    tan_theta = float(np.tan(np.radians(params.talus_angle)))
    dh, lost = tk.talus_automaton(h, grid.valid, fixed, grid.dx, grid.dy, tan_theta, fraction)
    area = grid.cell_area
    budget = MassBudget(float(np.maximum(-dh, 0.0).sum() * area),
                        float(np.maximum(dh, 0.0).sum() * area), float(lost))
    return SurfaceChange(dh, budget)
