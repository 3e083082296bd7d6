"""Fluvial erosion with sediment deposition, forward and backward in time (000 §3).

    ∂h/∂t = U − K·Q^m·|∇h|^n + (K_d/Q)·Q_s                                   (000 Eq. 3)

One step runs 000 Algorithm 1: a single pass over the cells in descending order of the
routing surface computes the discharge Q (000 Eq. 5), the new elevation (000 Eq. 8, deposition
from the sediment flux arriving from upstream) and the sediment flux leaving each cell
(000 Eq. 7). Forward steps (dt > 0) use the downstream slope (000 Eq. 9); backward steps
(dt < 0, unerosion and un-deposition) the limited blend of upwind and centred slopes
(000 Eq. 10–12), or the plain upwind slope for comparison.

Rivers may enter the domain from upstream of the map (000 §6.3.1, ``Inflow``): their discharge
is a source of water at the cell where they enter, added before accumulation (000 Eq. 5), and
their sediment flux arrives there as incoming Q_s in the descending pass (000 Eq. 7–8), so it
deposits downstream per K_d. The sediment brought in, dt·ΣQ_s,in (m³), is the budget's
``inflow`` term. Backward (dt < 0) the same inflow runs with time reversed: what it deposited
forward is un-deposited and leaves through the inflow cells, a negative ``inflow`` term, just
as material comes in through the outlets (a negative outflux).

The numba kernels are imported on first use, so that reading ``PARAMETERS`` (CLI help) does
not load numba.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.processes.budget import MassBudget
from unerode_cli.processes.parameters import UPLIFT, ParamSpec, check_fields

if TYPE_CHECKING:
    from unerode_cli.hydro.routing import Routing

Scheme = Literal["limiter", "upwind"]
SCHEMES: tuple[str, ...] = ("limiter", "upwind")

PARAMETERS: tuple[ParamSpec, ...] = (
    UPLIFT,
    ParamSpec(
        "k",
        "m^(1-3m)·y^(m-1)",
        1e-5,
        "fluvial erodibility K for a discharge Q in m³/y (000 Eq. 1); the default is not "
        "000 Table 2's range, which is for a discharge per unit width",
        minimum=0.0,
        raster=True,
        symbol="K",
    ),
    ParamSpec(
        "k_d",
        "m/y",
        1.0,
        "deposition coefficient K_d (000 Eq. 3): Yuan et al. 2019's G times the mean "
        "precipitation (default: G = 1 at 1 m/y); 0 gives the detachment-limited stream power law",
        minimum=0.0,
        raster=True,
        symbol="K_d",
    ),
    ParamSpec(
        "precipitation",
        "m/y",
        1.0,
        "precipitation rate p that makes the discharge Q (000 Eq. 2; 000 Table 2: 0-2 m/y)",
        minimum=0.0,
        raster=True,
        symbol="p",
    ),
    ParamSpec("m", "1", 0.4, "discharge exponent m (000 Eq. 1, Table 2)", 0.0, 2.0),
    ParamSpec("n", "1", 1.0, "slope exponent n (000 Eq. 1, Table 2)", 0.5, 4.0),
)
_SPECS = {spec.name: spec for spec in PARAMETERS}


@dataclass(frozen=True)
class FluvialParams:
    """Parameters of 000 Eq. 3; the four rates may be rasters (float[ny, nx]) on the grid.

    Attributes:
        uplift: U (m/y).
        k: K (m^(1−3m)·y^(m−1), with Q in m³/y).
        k_d: K_d (m/y).
        precipitation: p (m/y).
        m, n: stream power exponents (dimensionless).
    """

    uplift: float | np.ndarray = _SPECS["uplift"].default
    k: float | np.ndarray = _SPECS["k"].default
    k_d: float | np.ndarray = _SPECS["k_d"].default
    precipitation: float | np.ndarray = _SPECS["precipitation"].default
    m: float = _SPECS["m"].default
    n: float = _SPECS["n"].default

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for a value out of range inside the domain or a
        raster of another shape than the grid."""
        check_fields(self, PARAMETERS, grid)


@dataclass(frozen=True)
class Inflow:
    """Water and sediment entering the domain from upstream (000 §6.3.1), per cell.

    Attributes:
        discharge: float64[ny, nx] water discharge Q_in (m³/y) entering each cell, 0 where none.
        sediment: float64[ny, nx] sediment flux Q_s,in (m³/y) entering each cell, 0 where none.
    """

    discharge: np.ndarray
    sediment: np.ndarray


@dataclass(frozen=True)
class FluvialChange:
    """What one fluvial step does to the terrain.

    Attributes:
        dh: float64[ny, nx] elevation change (m), uplift U·dt included; 0 on outlets and nodata.
        sediment_flux: float64[ny, nx] Q_s (m³/y) leaving each cell; on outlets, what leaves
            the domain there.
        discharge: float[ny, nx] water discharge Q (m³/y); 0 on nodata (float64 from the
            explicit step, float32 from ``fluvial_implicit.step``).
        budget: the mass budget of the step.
    """

    dh: np.ndarray
    sediment_flux: np.ndarray
    discharge: np.ndarray
    budget: MassBudget


def slope_mode(dt: float, scheme: str) -> int:
    """Kernel slope mode of a step: downstream (000 Eq. 9) forward; backward the limited
    (Eq. 12) or upwind (Eq. 10) slope, per ``scheme``."""
    from unerode_cli.processes import fluvial_kernels as fk

    if scheme not in SCHEMES:
        raise ValueError(f"scheme must be one of {', '.join(SCHEMES)}, got {scheme!r}")
    if dt >= 0:
        return fk.DOWNSTREAM
    return fk.LIMITED if scheme == "limiter" else fk.UPWIND


def step(
    elevation: np.ndarray,
    grid: Grid,
    outlets: np.ndarray,
    params: FluvialParams,
    dt: float,
    routing: Routing | None = None,
    scheme: Scheme = "limiter",
    method: str = "mfd",
    inflow: Inflow | None = None,
    validated: bool = False,
) -> FluvialChange:
    """One step of fluvial erosion and deposition (dt > 0) or their reversal (dt < 0).

    Args:
        elevation: float64[ny, nx] elevation h(t) (m); not modified.
        grid: cell sizes and domain.
        outlets: bool[ny, nx] base-level cells (outlets, Dirichlet nodes): they keep their
            elevation and let sediment out.
        params: the parameters of 000 Eq. 3.
        dt: time step (y); negative to go back in time.
        routing: the routing of ``elevation`` towards ``outlets`` (``unerode_cli.hydro.route``);
            computed here with ``method`` when not given.
        scheme: slope of backward steps: ``"limiter"`` (000 Eq. 12) or ``"upwind"`` (Eq. 10).
        method: routing method when ``routing`` is not given: ``"mfd"`` or ``"d8"``.
        inflow: water and sediment entering the domain (m³/y per cell), or None.
        validated: ``params`` were already checked on ``grid`` (``FluvialParams.validate``),
            e.g. by a process that steps with the same parameters again and again.

    Returns:
        the change (Δh with the uplift U·dt included), the fluxes Q and Q_s and the mass budget
        (eroded + inflow − deposited − outflux = 0).
    """
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.hydro.routing import cell_sources, route, scratch
    from unerode_cli.processes import fluvial_kernels as fk

    if not validated:
        params.validate(grid)
    mode = slope_mode(dt, scheme)
    if routing is None:
        routing = route(elevation, grid, outlets, method)
    elif outlets is not routing.outlets and not np.array_equal(routing.outlets,
                                                               outlets & grid.valid):
        raise ValueError("the routing was computed with other outlets than the ones given")
    h = np.ascontiguousarray(elevation, dtype=np.float64)
    shape = grid.shape
    order = routing.order
    slope = scratch("fluvial.slope", (h.size,), np.float64)
    fk.slope_into(h, grid.valid, grid.dx, grid.dy, mode, slope)
    # The powers of the slope in parallel, then Algorithm 1's serial pass (Q, E, D, Qs), then
    # Δh and the budget in parallel. Per-cell terms go by position in the order, so the
    # serial pass reads them in sequence.
    coef = scratch("fluvial.coef", order.shape, np.float64)
    fk.erodibility_into(order, slope, flat_field(params.k, shape, "k"), float(params.n), coef)
    discharge = np.zeros(shape, dtype=np.float64)
    sources = cell_sources(grid, params.precipitation)
    if inflow is None:
        sediment_flux = np.zeros(shape, dtype=np.float64)
    else:
        sources = sources + flat_field(inflow.discharge, shape, "inflow discharge")
        sediment_flux = flat_field(inflow.sediment, shape, "inflow sediment").reshape(shape).copy()
    net = scratch("fluvial.net", order.shape, np.float64)
    fk.fluvial_sweep_into(
        routing.filled, routing.outlets, order, grid.dx, grid.dy, routing.single, sources, coef,
        flat_field(params.k_d, shape, "k_d"), float(params.m), discharge.ravel(),
        sediment_flux.ravel(), net,
    )
    dh = np.zeros(shape, dtype=np.float64)
    erosion, deposition, outflow = fk.settle_into(
        order, net, sediment_flux.ravel(), routing.outlets.ravel(),
        flat_field(params.uplift, shape, "uplift"), float(dt), grid.cell_area, dh.ravel(),
    )
    removed, added = (erosion, deposition) if dt >= 0 else (deposition, erosion)
    brought = 0.0 if inflow is None else float(np.sum(inflow.sediment, dtype=np.float64))
    budget = MassBudget(abs(dt) * removed, abs(dt) * added, dt * outflow, dt * brought)
    return FluvialChange(dh, sediment_flux, discharge, budget)


def max_stable_dt(
    elevation: np.ndarray,
    grid: Grid,
    params: FluvialParams,
    routing: Routing,
    courant: float = 1.0,
    discharge: np.ndarray | None = None,
    validated: bool = False,
) -> float:
    """Largest |dt| (y) for which the explicit stream power term is stable (CFL, 000 §6).

    The stream power term moves elevation changes upstream at the speed
    c = n·K·Q^m·|∇h|^(n−1) (m/y; K·Q^m for n = 1). Along a diagonal, the magnitude of the
    downstream gradient (000 Eq. 9) reacts to the cell's own elevation with the weight
    sqrt(1/dx² + 1/dy²), so the bound, valid in every flow direction, is

        |dt| ≤ courant / (max c · sqrt(1/dx² + 1/dy²)),

    i.e. K·Q^m·|dt|·√2/Δx ≤ 1 on a square grid. Returns ``inf`` when nothing erodes. The
    deposition term does not restrict the step (000 §6). ``discharge`` (m³/y, float[ny, nx]),
    when given, is the discharge of ``routing`` (e.g. ``FluvialChange.discharge`` of a step
    on this elevation, inflow included) and saves computing it again; without it, the
    discharge of the precipitation alone. ``validated``: as for :func:`step`.
    """
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.hydro.routing import accumulate, scratch
    from unerode_cli.processes import fluvial_kernels as fk

    if not validated:
        params.validate(grid)
    h = np.ascontiguousarray(elevation, dtype=np.float64)
    if discharge is None:
        discharge = accumulate(routing, params.precipitation)
    q = np.ascontiguousarray(discharge, dtype=np.float64).ravel()
    k = flat_field(params.k, grid.shape, "k")
    free = (grid.valid & ~routing.outlets).ravel()
    m, n = float(params.m), float(params.n)
    if k.size == 1 and n == 1.0:
        # max_speed's own shortcut, K·(max Q)^m, without its parallel region, which costs more
        # to start than this one reduction (milliseconds when the other cores are busy)
        q_max = float(np.max(q, where=free, initial=0.0))
        speed = float(k[0]) * q_max**m if q_max > 0.0 else 0.0
    else:
        slope = scratch("fluvial.slope", (h.size,), np.float64)
        fk.slope_into(h, grid.valid, grid.dx, grid.dy, fk.DOWNSTREAM, slope)
        speed = fk.max_speed(q, slope, free, k, m, n)
    if speed == 0.0:
        return float("inf")
    return courant / (speed * float(np.hypot(1.0 / grid.dx, 1.0 / grid.dy)))
