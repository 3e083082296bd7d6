"""Implicit forward fluvial erosion with deposition: 000 Eq. 3 stable at any time step.

    ∂h/∂t = U − K·Q^m·S^n + (K_d/Q)·Q̃s                                        (000 Eq. 3)

The stream power term is implicit in the new elevations (Braun & Willett 2013, "FastScape"):
cells are solved receivers first, each from its receivers' end-of-step elevations, in O(N)
per pass; for n = 1 each cell's equation is linear, for n ≠ 1 it is solved by a bracketed
Newton iteration. The deposition term is iterated to convergence as in Yuan et al. (2019,
JGR Earth Surface 124, §3.2): elevations from the deposition rates, then the sediment flux and
new deposition rates from the elevations, until the rates settle.

The slope S is taken along the routing's receivers, whose weights are those of the step's
start. With D8 it is the slope to the steepest receiver, (h − h_r)/L (Braun & Willett 2013, as
fastscapelib's ``SPLEroder``); it equals the gradient magnitude of the explicit step (000
Eq. 9) on planes dipping along an axis or a diagonal and is up to 8 % lower in between. With MFD
it is the receiver-weighted slope c·Σ_k w_k·(h − h_k)/L_k (000 Eq. 6 weights w_k, distances
L_k), with c set per cell so that S equals 000 Eq. 9's |∇h| at the start of the step: the
weighted sum alone is a fixed share of the gradient (2/(1+√2) ≈ 0.83 on an axis-aligned plane),
which would erode less than the law asks for.

A cell whose elevation lies below the routing surface (under a lake of the depression filling)
is not incised: the water stands and the sediment arriving settles there by K_d/Q. (Incising
such cells at the slope of the real surface, as the explicit step does, makes the deposition
iteration cycle: their receivers on the filled surface are arbitrary.)

Two layouts of the step's arrays give the same step to rounding: ``"ordered"`` copies them in
the routing's order with each cell's receivers listed (``fluvial_implicit_kernels``: the
faster, about 60 bytes a cell more), ``"lean"`` keeps them where the cells lie and works the
receivers out again in each pass (``fluvial_implicit_lean_kernels``: 4 bytes a cell more).

Backward steps (unerosion) keep the explicit limiter scheme of ``fluvial.step``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.processes.budget import MassBudget
from unerode_cli.processes.fluvial import FluvialChange, FluvialParams, Inflow

if TYPE_CHECKING:
    from unerode_cli.hydro.routing import Routing

#: The deposition iteration ends when no cell's deposition over the step changed by more than
#: this share of the step's largest elevation change (or :data:`ATOL`).
RTOL = 1e-6
#: ... or than this many metres.
ATOL = 1e-9
#: Most passes of the deposition iteration in one step.
MAX_PASSES = 500
#: Layouts of the step's arrays (see :func:`step`).
LAYOUTS = ("ordered", "lean")
#: Bytes per cell an ordered-layout step allocates beyond what a run holds when the step
#: starts (elevations, routing): the step's own arrays (Q, new elevations, Q_s, deposition
#: rates: 28) and what the ordered layout holds beyond the lean one (in-order copies, receiver
#: lists with MFD's fractions, the cell-to-position map: 58 measured at 8192², MFD); rounded up.
ORDERED_EXTRA_BYTES_PER_CELL = 96


@dataclass(frozen=True)
class ImplicitStep:
    """An implicit step: its change, and how the deposition iteration ended.

    Attributes:
        change: Δh (uplift included), fluxes and mass budget, as ``fluvial.step`` gives them.
        passes: passes of the deposition iteration (1 without deposition).
        residual: largest change of a cell's deposition over the step in the last pass, as a
            share of the tolerance (≤ 1: converged).
        deposition: float64[ny, nx] deposition rates D of the last pass (m/y).
    """

    change: FluvialChange
    passes: int
    residual: float
    deposition: np.ndarray

    @property
    def converged(self) -> bool:
        return self.residual <= 1.0


def step(
    elevation: np.ndarray,
    grid: Grid,
    outlets: np.ndarray,
    params: FluvialParams,
    dt: float,
    routing: Routing | None = None,
    method: str = "mfd",
    inflow: Inflow | None = None,
    validated: bool = False,
    rtol: float = RTOL,
    max_passes: int = MAX_PASSES,
    deposition: np.ndarray | None = None,
    layout: str = "ordered",
) -> ImplicitStep:
    """One implicit forward step of fluvial erosion and deposition (dt > 0).

    Args:
        elevation: float64[ny, nx] elevation h(t) (m); not modified.
        grid, outlets, params, routing, method, inflow, validated: as for ``fluvial.step``.
        dt: time step (y), > 0; any length is stable.
        rtol: tolerance of the deposition iteration (share of the largest |Δh|).
        max_passes: most passes of the deposition iteration.
        deposition: float64[ny, nx] first guess of the deposition rates D (m/y), e.g. the
            previous step's ``ImplicitStep.deposition`` (updated in place); 0 when None.
        layout: ``"ordered"`` or ``"lean"`` (see the module docstring).

    Returns:
        the change with Q (float32), Q_s and the mass budget (eroded + inflow − deposited −
        outflux = 0 to rounding), and how the iteration ended.

    Raises:
        FloatingPointError: K·Q^m·dt overflows (no step can be computed).
    """
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.hydro.routing import cell_sources, route

    if not dt > 0.0:
        raise ValueError(f"the implicit step runs forward in time (dt > 0), got dt = {dt:g}")
    if not validated:
        params.validate(grid)
    if routing is None:
        routing = route(elevation, grid, outlets, method)
    elif outlets is not routing.outlets and not np.array_equal(routing.outlets, outlets & grid.valid):
        raise ValueError("the routing was computed with other outlets than the ones given")
    shape = grid.shape
    h0 = np.ascontiguousarray(elevation, dtype=np.float64).ravel()
    sources = cell_sources(grid, params.precipitation)
    if layout not in LAYOUTS:
        raise ValueError(f"the layout must be one of {', '.join(LAYOUTS)}, got {layout!r}")
    if inflow is None:
        sediment_in = np.zeros(1, dtype=np.float64)
    else:
        sources = sources + flat_field(inflow.discharge, shape, "inflow discharge")
        sediment_in = flat_field(inflow.sediment, shape, "inflow sediment")
    discharge = _discharge(routing, grid, sources)
    k = flat_field(params.k, shape, "k")
    q_max = float(discharge.max(initial=0.0))
    if not np.isfinite(float(k.max(initial=0.0)) * q_max ** float(params.m) * dt):
        raise FloatingPointError("K·Q^m·dt overflows: the erodibility is too large")
    new = np.empty_like(h0)
    rates = _first_rates(deposition, shape)
    sediment_flux = np.empty(shape, dtype=np.float64)
    uplift = flat_field(params.uplift, shape, "uplift")
    sweep = _sweep if layout == "ordered" else _lean_sweep
    passes, residual, eroded, deposited, outflow = sweep(
        h0, grid, routing, params, dt, discharge.ravel(), k, uplift, sediment_in, rtol, max_passes, new,
        sediment_flux.ravel(), rates.ravel())
    dh = new.reshape(shape)
    dh -= h0.reshape(shape)
    dh[~grid.valid] = 0.0
    # a flux set to 0 where more was deposited than arrived (before convergence) shows as a
    # budget residual: it is not hidden in a term
    budget = MassBudget(dt * eroded, dt * deposited, dt * outflow,
                        dt * float(np.sum(sediment_in, dtype=np.float64)))
    change = FluvialChange(dh, sediment_flux, discharge, budget)
    return ImplicitStep(change, int(passes), float(residual), rates)


def _discharge(routing: Routing, grid: Grid, sources: np.ndarray) -> np.ndarray:
    """float32[ny, nx] discharge Q (m³/y): accumulated in float64 (000 Eq. 5), held in float32
    (K·Q^m·dt and the trapping K_d/Q read it to 6e-8 of their value; the float64 grid goes
    before the step's other arrays are made)."""
    from unerode_cli.hydro.kernels import accumulate_into

    accumulated = np.zeros(grid.shape, dtype=np.float64)
    accumulate_into(routing.filled, routing.outlets, routing.order, grid.dx, grid.dy, routing.single,
                    sources, accumulated.ravel())
    return accumulated.astype(np.float32)


def _first_rates(deposition: np.ndarray | None, shape: tuple[int, int]) -> np.ndarray:
    """The deposition rates the iteration starts from and updates: ``deposition`` itself when
    it is a C-contiguous float64 array of ``shape``, else a float64 copy; zeros without."""
    if deposition is None:
        return np.zeros(shape, dtype=np.float64)
    if (deposition.shape == shape and deposition.dtype == np.float64 and deposition.flags.c_contiguous
            and deposition.flags.writeable):
        return deposition
    return np.array(deposition, dtype=np.float64).reshape(shape)


def _lean_sweep(h0: np.ndarray, grid: Grid, routing: Routing, params: FluvialParams, dt: float,
                discharge: np.ndarray, k: np.ndarray, uplift: np.ndarray, sediment_in: np.ndarray,
                rtol: float, max_passes: int, new: np.ndarray, sediment_flux: np.ndarray,
                rates: np.ndarray) -> tuple[int, float, float, float, float]:
    """The kernel of the step on cell-indexed arrays (the lean layout)."""
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.processes import fluvial_implicit_lean_kernels as lean

    shape = grid.shape
    done = lean.lean_sweep_into(
        h0.reshape(shape), grid.valid, routing.filled, routing.outlets, routing.order, grid.dx, grid.dy,
        routing.single, discharge, k, float(params.n), float(params.m), flat_field(params.k_d, shape, "k_d"),
        uplift, float(dt), sediment_in, float(rtol), ATOL, int(max_passes), new, sediment_flux, rates,
        np.empty(h0.size, dtype=np.float32))
    passes, residual, _clipped, eroded, deposited, outflow = done
    return int(passes), float(residual), float(eroded), float(deposited), float(outflow)


def _sweep(h0: np.ndarray, grid: Grid, routing: Routing, params: FluvialParams, dt: float,
           discharge: np.ndarray, k: np.ndarray, uplift: np.ndarray, sediment_in: np.ndarray,
           rtol: float, max_passes: int, new: np.ndarray, sediment_flux: np.ndarray,
           rates: np.ndarray) -> tuple[int, float, float, float, float]:
    """The kernel of the step, on arrays in the routing's order. Fills
    ``new``, ``sediment_flux`` and ``rates`` (flat); returns (passes, residual, erosion,
    deposition and outflux rates in m³/y)."""
    from unerode_cli.hydro.fields import flat_field
    from unerode_cli.hydro.routing import scratch
    from unerode_cli.processes import fluvial_implicit_kernels as fik

    shape, order = grid.shape, routing.order
    fields = (flat_field(params.k_d, shape, "k_d"), uplift, float(dt))
    done = fik.implicit_sweep_into(
        h0, grid.valid, routing.filled, routing.outlets, order, grid.dx, grid.dy, routing.single, discharge,
        k, float(params.n), float(params.m), *fields, sediment_in, float(rtol), ATOL, int(max_passes), new,
        sediment_flux, rates, scratch("fluvial_implicit.work", (4, order.size), np.float64),
        scratch("fluvial_implicit.work32", (2, order.size), np.float32),
        scratch("fluvial_implicit.position", (h0.size,), order.dtype.type))
    passes, residual, _clipped, eroded, deposited, outflow = done
    return int(passes), float(residual), float(eroded), float(deposited), float(outflow)
