"""Thermal erosion with rock deposition, forward and backward in time (000 §4).

    ∂h/∂t = −K_th·max(0, |∇h| − tan θ) + K_thd·Q_r                           (000 Eq. 14)

Rocks detach where the slope exceeds the talus slope tan θ; the rock discharge Q_r (000 Eq. 13)
is routed downslope like the fluvial sediment flux and deposited where the slope is below tan θ,
as much as the slope allows (000 Eq. 15). One step is a single pass over the cells in the order
of the flow routing (000 Algorithm 1). Backward (dt < 0) the cells above the talus slope are
un-eroded and the rock is taken back from the cells below, with the un-deposition constraints
of 000 §4.2: slope (Eq. 16, α), convexity at the foot of un-eroded cliffs (Eq. 17) and a
maximal un-deposition rate. Any of them can be switched off (000 Fig. 10).

Unit of K_th: m/ky, metres of lowering per 1000 years of a cell whose slope exceeds tan θ by 1
(m/m); the kernels take K_th / 1000 in m/y (:func:`per_year`). 000 Table 2 gives K_th in
"(1000 years)⁻¹", range [0, 0.5], with Δt = 1000 years and h in m; 000 Eq. 15 lowers a cell by
Δt·K_th·(|∇h| − tan θ) metres, so K_th·Δt is a length and the unit left implicit by Table 2 is
the metre of h: K_th is in m per 1000 years. 000 §5.2 schedules 0.002 (interglacial) to 0.008
(glacial). Readings weighed (the table's unit is ambiguous):

- m/ky (this one): 0.008 lowers a cell one unit of slope above tan θ by 8 mm per 1 ky step, at
  most ≈ 6.5 m over Tautavel's 814 ka and ≈ 40 m over the Têt's 5 Ma, below the +4 to +20 m
  terraces and the ≈ 260 m incision (55–92 mm/ka) that 000 §6.3 attributes to the rivers: thermal
  erosion "is significantly slower" (000 §1). The CFL limit Δx/(√2·K_th) (ky) is 177 ky on 2 m cells
  and 2.7 My on 30 m cells; even Table 2's largest 0.5 gives 2.8 ky on 2 m cells, so every
  combination of Table 2 (Δx 2–30 m, Δt 1000 years) is stable, as 000 §6 says its runs are. The
  e-folding time of cliffs growing backward, ≈ Δx/K_th, is 3.75 My on 30 m cells.
- m/y: 0.008 would move 8 m per step, 6.5 km over 814 ka; Δx/(√2·K_th) is 177 years on 2 m cells
  (2.8 years for 0.5), far below the paper's 1000-year step, and thermal unerosion of 30 m cells
  e-folds every ≈ 4 ky, so the case studies diverge.
- a fraction per ky of the cell's excess height Δx·(|∇h| − tan θ) (the cellular automaton's
  "proportion", 000 §4.1): it puts a Δx in the erosion term of 000 Eq. 15 that the equation
  does not have, and makes the rate depend on the resolution (30 × m/ky on 30 m cells).

000 Fig. 3, 6, 9 and 10 give no metres; Fig. 4 and 6 run 200 iterations of 1000 years, Fig. 9
100 ky. With m/y and 0.008 a cliff one unit above tan θ would lose 1.6 km in 200 iterations,
more than the relief of the terrains shown, which keep their shape; with m/ky it loses 1.6 m, and
Table 2's upper range (0.5 m/ky: 100 m) makes the cliff retreat visible in such figures.

On the 256 × 256 sample valley (30 m cells, relief 2087 m) along LR04 with the 000 Table 1
schedule, unerosion with ``thermal,fluvial`` read as m/y diverged (cells 10 km off) at 256 ka
(Tautavel, Δt 1 ky) and 156 ka (Têt, Δt 2 ky); read as m/ky it reaches 814 ka, and thermal
unerosion alone moves cells by at most 130 m over 814 ka (mean 6.9 m) and 221 m over 3 Ma.

The numba kernels are imported on first use (``PARAMETERS`` is read for the CLI help).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.processes.budget import MassBudget
from unerode_cli.processes.fluvial import slope_mode
from unerode_cli.processes.parameters import ParamSpec, check_fields

if TYPE_CHECKING:
    from unerode_cli.hydro.routing import Routing

K_TH = ParamSpec(
    "k_th",
    "m/ky",
    0.002,
    "thermal erodibility K_th: lowering per 1000 years per unit of slope above the talus slope "
    "(000 Eq. 14; Table 2: (1000 years)⁻¹; 000 §5.2: 0.002 interglacial, 0.008 glacial)",
    minimum=0.0,
    raster=True,
    symbol="K_th",
)
TALUS_ANGLE = ParamSpec(
    "talus_angle", "degrees", 30.0, "talus angle θ above which rock detaches (000 Eq. 14)",
    minimum=0.0, maximum=89.0, symbol="theta",
)
PARAMETERS: tuple[ParamSpec, ...] = (
    K_TH,
    TALUS_ANGLE,
    ParamSpec(
        "alpha", "1", 1.0,
        "α of the un-deposition slope constraint h(t−Δt) ≥ h(t) − α·Δx·S_d (000 Eq. 16; "
        "000 Fig. 10 uses 1)",
        minimum=0.0, maximum=10.0,
    ),
    ParamSpec(
        "max_undeposition", "m/y", 0.01,
        "largest rate at which thermal unerosion lowers a deposit (000 §4.2, 'max un-deposition')",
        minimum=0.0, raster=False,
    ),
)
_SPECS = {spec.name: spec for spec in PARAMETERS}

#: Years in the ky of K_th's unit (m/ky): the kernels take K_th / YEARS_PER_KY in m/y.
YEARS_PER_KY = 1000.0

#: Names of the un-deposition constraints of backward steps (000 §4.2).
CONSTRAINTS: tuple[str, ...] = ("slope", "convexity", "rate")


@dataclass(frozen=True)
class ThermalParams:
    """Parameters of 000 Eq. 14–17.

    Attributes:
        k_th: K_th (m/ky), scalar or float[ny, nx].
        talus_angle: θ (degrees).
        alpha: α of 000 Eq. 16 (dimensionless).
        max_undeposition: maximal un-deposition rate (m/y).
    """

    k_th: float | np.ndarray = _SPECS["k_th"].default
    talus_angle: float = _SPECS["talus_angle"].default
    alpha: float = _SPECS["alpha"].default
    max_undeposition: float = _SPECS["max_undeposition"].default

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for a value out of range or of the wrong shape."""
        check_fields(self, PARAMETERS, grid)

    @property
    def tan_theta(self) -> float:
        return math.tan(math.radians(self.talus_angle))


@dataclass(frozen=True)
class ThermalChange:
    """What one thermal step does.

    Attributes:
        dh: float64[ny, nx] elevation change (m); 0 on outlets and nodata.
        rock_flux: float64[ny, nx] rock discharge Q_r leaving each cell (m³/y).
        budget: volumes taken from and added to the surface, and through the outlets (m³).
    """

    dh: np.ndarray
    rock_flux: np.ndarray
    budget: MassBudget


def per_year(k_th: float | np.ndarray) -> float | np.ndarray:
    """K_th in m/ky (the unit users give, 000 Table 2) → m/y (the unit of the kernels' dt)."""
    return k_th / YEARS_PER_KY


def constraint_flags(names: Iterable[str]) -> int:
    """``["slope", "rate"]`` → kernel bit flags; ValueError for an unknown name."""
    from unerode_cli.processes import thermal_kernels as tk

    bits = {"slope": tk.SLOPE_LIMIT, "convexity": tk.CONVEXITY, "rate": tk.RATE_LIMIT}
    flags = 0
    for name in names:
        if name not in bits:
            raise ValueError(f"unknown un-deposition constraint {name!r}; choose from "
                             f"{', '.join(CONSTRAINTS)}")
        flags |= bits[name]
    return flags


def step(
    elevation: np.ndarray,
    grid: Grid,
    outlets: np.ndarray,
    params: ThermalParams,
    dt: float,
    routing: Routing | None = None,
    scheme: str = "limiter",
    constraints: Iterable[str] = CONSTRAINTS,
    method: str = "mfd",
) -> ThermalChange:
    """One step of thermal erosion and deposition (dt > 0) or of their reversal (dt < 0).

    Args:
        elevation: float64[ny, nx] elevation h(t) (m); not modified.
        grid: cell sizes and domain.
        outlets: bool[ny, nx] base-level cells: they keep their elevation and let rock out.
        params: the parameters of 000 Eq. 14–17.
        dt: time step (y); negative to go back in time.
        routing: routing of ``elevation`` towards ``outlets``; computed with ``method`` if None.
        scheme: slope deciding unerosion in backward steps: ``"limiter"`` (000 Eq. 12) or
            ``"upwind"`` (000 Eq. 10); forward steps use the downstream slope (000 Eq. 9).
        constraints: un-deposition constraints applied backward, among ``CONSTRAINTS``.
        method: routing method when ``routing`` is not given.

    Returns:
        the change, the rock discharge and the mass budget (eroded − deposited − outflux = 0).
    """
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.hydro.routing import route
    from unerode_cli.processes import thermal_kernels as tk

    params.validate(grid)
    flags = constraint_flags(constraints)
    if routing is None:
        routing = route(elevation, grid, outlets, method)
    h = np.ascontiguousarray(elevation, dtype=np.float64)
    slope, down = _slopes(h, grid, dt, scheme)
    dh, rock, removed, added, outflow = tk.thermal_sweep(
        routing.filled, h, grid.valid, routing.outlets, routing.order, grid.dx, grid.dy,
        routing.single, slope, down, flat_field(per_year(params.k_th), grid.shape, "k_th"),
        params.tan_theta, float(dt), float(params.alpha), float(params.max_undeposition), flags,
    )
    budget = MassBudget(removed, added, dt * outflow)
    return ThermalChange(dh.reshape(grid.shape), rock.reshape(grid.shape), budget)


def _slopes(h: np.ndarray, grid: Grid, dt: float, scheme: str) -> tuple[np.ndarray, np.ndarray]:
    """(slope deciding erosion, downstream slope S_d), flat (m/m): forward both are the
    downstream slope (000 Eq. 9); backward the first is limited (Eq. 12) or upwind (Eq. 10)."""
    from unerode_cli.processes import fluvial_kernels as fk

    mode = slope_mode(dt, scheme)
    down = fk.slope_magnitude(h, grid.valid, grid.dx, grid.dy, fk.DOWNSTREAM)
    if mode == fk.DOWNSTREAM:
        return down, down
    return fk.slope_magnitude(h, grid.valid, grid.dx, grid.dy, mode), down


def max_stable_dt(elevation: np.ndarray, grid: Grid, params: ThermalParams, outlets: np.ndarray,
                  dt_sign: float = 1.0, scheme: str = "limiter", courant: float = 1.0) -> float:
    """Largest |dt| (y) for which the explicit erosion term of 000 Eq. 14 is stable (CFL).

    The term moves elevation changes upslope at the speed K_th / 1000 (m/y, K_th in m/ky), so
    |dt| ≤ courant / (max K_th/1000 · sqrt(1/dx² + 1/dy²)) over the cells steeper than tan θ (with
    the slope of a step of sign ``dt_sign``); ``inf`` when no cell is. Deposition does not
    restrict the step: it is capped by the slope.
    """
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.processes import thermal_kernels as tk

    params.validate(grid)
    h = np.ascontiguousarray(elevation, dtype=np.float64)
    slope, _ = _slopes(h, grid, dt_sign, scheme)
    free = (grid.valid & ~outlets).ravel()
    speed = tk.max_speed(slope, free, flat_field(per_year(params.k_th), grid.shape, "k_th"),
                         params.tan_theta)
    if speed == 0.0:
        return float("inf")
    return courant / (speed * float(np.hypot(1.0 / grid.dx, 1.0 / grid.dy)))
