"""Debris-flow erosion of steep slopes (001 §6.2).

    ∂z/∂t = −k_df·(1 + k_da·A^q)·max(0, |∇z| − s_c)^q'                         (001 Eq. 8)

A: drainage area (m²) accumulated along the steepest descent (D8) on the depression-filled
routing surface, as in 001 §6.2; s_c = tan(critical angle).

Discretisation, and how it differs from the paper: 001 solves Eq. 8 explicitly with the
Euclidean norm of the downward x and y slopes, which is stable only for
dt < L / (q'·K'·(|∇z| − s_c)^(q'−1)) (K' = k_df·(1 + k_da·A^q)) — with Table 1's values and
A in m², K' reaches 1 m/y at A ≈ 1 ha, so steps of a few tens of years at most on a 30 m grid
(L = 30 m, |∇z| − s_c = 0.5). Here Eq. 8 is solved implicitly, as Braun & Willett (2013)
do for the stream power law: cells are solved downstream first, and |∇z| is the
steepest-descent (D8) slope at the end of the step towards the neighbours already solved
(the D8 receiver among them), each cell's equation solved exactly (closed form for q' = 1, 2,
safeguarded Newton otherwise; ``debris_kernels``). Any dt ≥ 0 is then stable: slopes relax
towards s_c and never below it, no cell becomes a pit, and a very long step leaves every
eroding cell at the critical slope over its steepest-descent neighbour. Small steps agree with
the explicit scheme to first order in dt. On a plane the D8 slope equals |∇z| when the
steepest descent points to one of the 8 neighbours, and is smaller otherwise (by a factor
cos 22.5° ≈ 0.92 at worst on a square grid), so the effective s_c is up to ~8 % steeper in
those directions.

The eroded debris is carried out of the model (001 has no deposition of it): nothing is
deposited, and the whole eroded volume counts as outflux. Forward only (``BACKWARD_REFUSAL``).

The numba kernels are imported on first use, so that reading ``PARAMETERS`` (CLI help) does
not load numba.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.processes.budget import MassBudget, SurfaceChange
from unerode_cli.processes.parameters import ParamSpec, check_fields

if TYPE_CHECKING:
    from unerode_cli.hydro.routing import Routing

#: Why ``step`` refuses dt < 0 (the command line prints it for ``unerode --process debris``).
BACKWARD_REFUSAL = (
    "debris flow cannot run backward in time: its implicit scheme is not reversible (every "
    "slope steeper than the critical one relaxes towards it, so where it started is lost) "
    "and 001 gives no backward form of it."
)

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "k_df",
        "m/y",
        1e-4,
        "debris-flow erodibility k_df (001 Eq. 8; 001 Table 1: 1e-4 to 2.5e-4); m/y since "
        "(1 + k_da·A^q) and the slope are dimensionless",
        minimum=0.0,
        raster=True,
        symbol="K_df",
    ),
    ParamSpec(
        "k_da",
        "m^(-2q)",
        10.0,
        "weight k_da of the drainage area A (m²) in the debris-flow erosion (001 Eq. 8, Table 1)",
        minimum=0.0,
    ),
    ParamSpec(
        "q_area",
        "1",
        0.8,
        "drainage area exponent q of the debris-flow erosion (001 Eq. 8, Table 1)",
        minimum=0.0,
        maximum=2.0,
    ),
    ParamSpec(
        "q_slope",
        "1",
        2.0,
        "exponent q' of the slope above the critical one (001 Eq. 8, Table 1)",
        minimum=1.0,
    ),
    ParamSpec(
        "critical_angle",
        "degrees",
        37.0,
        "critical slope angle below which debris flows do not erode, s_c = tan(angle) "
        "(001 Eq. 8; 001 Table 1: 37°); strictly between 0 and 90",
        minimum=0.0,
        maximum=90.0,
        symbol="s_c",
    ),
)
_SPECS = {spec.name: spec for spec in PARAMETERS}


@dataclass(frozen=True)
class DebrisParams:
    """Parameters of 001 Eq. 8; ``k_df`` may be a raster (float[ny, nx]) on the grid.

    Attributes:
        k_df: erodibility k_df (m/y).
        k_da: weight of the drainage area k_da (m^(−2q), A in m²).
        q_area: drainage area exponent q (dimensionless).
        q_slope: slope exponent q' ≥ 1 (dimensionless).
        critical_angle: θ_c (degrees, 0 < θ_c < 90); s_c = tan θ_c.
    """

    k_df: float | np.ndarray = _SPECS["k_df"].default
    k_da: float = _SPECS["k_da"].default
    q_area: float = _SPECS["q_area"].default
    q_slope: float = _SPECS["q_slope"].default
    critical_angle: float = _SPECS["critical_angle"].default

    @property
    def critical_slope(self) -> float:
        """s_c = tan(critical_angle) (m/m)."""
        return math.tan(math.radians(float(self.critical_angle)))

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for a value out of range inside the domain or a
        raster of another shape than the grid."""
        check_fields(self, PARAMETERS, grid)
        if not 0.0 < float(self.critical_angle) < 90.0:
            raise ValueError(
                f"parameter critical_angle must be strictly between 0 and 90 degrees, "
                f"got {float(self.critical_angle):g}"
            )


def step(
    elevation: np.ndarray,
    grid: Grid,
    fixed: np.ndarray,
    params: DebrisParams,
    dt: float,
    routing: Routing | None = None,
) -> SurfaceChange:
    """One implicit step of debris-flow erosion (001 Eq. 8).

    Each cell is lowered by Δh = −dt·k_df·(1 + k_da·A^q)·max(0, S⁺ − s_c)^q', with S⁺ its
    steepest-descent slope at the end of the step towards the neighbours downstream of it in
    the routing order (see the module docstring for why implicit, and
    ``debris_kernels.debris_sweep`` for the solve). Unconditionally stable: any dt ≥ 0, no
    ``max_stable_dt``. No uplift (the runner applies it once for all processes).

    Args:
        elevation: float64[ny, nx] elevation z(t) (m); not modified. Nodata values are not read.
        grid: cell sizes and domain.
        fixed: bool[ny, nx] outlets (base level, Dirichlet nodes): they keep their elevation.
        params: the parameters of 001 Eq. 8.
        dt: time step (y), ≥ 0.
        routing: the routing of ``elevation`` towards ``fixed`` (``unerode_cli.hydro.route``);
            computed here with D8 when not given. It gives the order of the cells and the
            drainage area A, accumulated with its method (D8 as in 001 §6.2 when computed
            here; an MFD routing shared with fluvial erosion gives the MFD area).

    Returns:
        The change: Δh (m, ≤ 0; 0 on fixed and nodata cells) and the mass budget: eroded =
        Σ −Δh·dx·dy (m³), deposited = 0, outflux = eroded — the debris is carried out of the
        model, not deposited downstream.

    Raises:
        ValueError: dt < 0 (``BACKWARD_REFUSAL``), non-finite dt, a parameter out of range, a
            routing computed with other outlets, or any error of ``route`` (no outlet, ...).
    """
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.hydro.routing import drainage_area, route
    from unerode_cli.processes import debris_kernels as dk

    dt = float(dt)
    if dt < 0:
        raise ValueError(BACKWARD_REFUSAL)
    if not np.isfinite(dt):
        raise ValueError(f"the time step must be finite, got {dt} y")
    params.validate(grid)
    fixed = np.asarray(fixed, dtype=bool)
    if routing is None:
        routing = route(elevation, grid, fixed, "d8")
    elif not np.array_equal(routing.outlets, fixed & grid.valid):
        raise ValueError("the routing was computed with other outlets than the fixed cells given")
    shape = grid.shape
    h = np.ascontiguousarray(elevation, dtype=np.float64)
    area = drainage_area(routing).ravel()
    dh = dk.debris_sweep(
        h,
        routing.outlets,
        routing.order,
        area,
        grid.dx,
        grid.dy,
        flat_field(params.k_df, shape, "k_df"),
        float(params.k_da),
        float(params.q_area),
        float(params.q_slope),
        params.critical_slope,
        dt,
    )
    eroded = float(-dh.sum() * grid.cell_area)
    return SurfaceChange(dh.reshape(shape), MassBudget(eroded, 0.0, eroded))
