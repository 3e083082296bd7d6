"""Coupled glacier time stepping (001 §3.2, Fig. 3): mass balance → ice flow → transport → erosion.

One step of length dt (y) from the state (bed b, ice thickness H, time t):

1. mass balance M = min(p_max, β·(s − E(t))) on the surface s = b + H (001 Eq. 2), E taken at
   the start of the step (a number, a raster, or a function of time, e.g. ``ElaTable``);
2. ice velocities of the geometry (b, H): Blatter–Pattyn (``blatter.solve``, 001 Eq. 7) or the
   shallow-ice approximation with Weertman sliding (``sia_flow``);
3. transport ∂H/∂t = M − ∇·(Hū) (001 Eq. 1): adaptive multi-scale steps (``multiscale``, 001 §5,
   the default) or explicit steps (``transport``) cut into sub-steps that respect their
   stability limit (``UnstableStep`` where sub-steps are refused);
4. glacial erosion of the bed by the sliding ice (``erosion``, 001 §6.1): b ← b + dt·(abrasion +
   quarrying), from the basal velocity of step 2; the cells of ``CoupledParams.edge_cells`` (the
   map's open edges and nodata borders) are lowered as the nearest interior cell is, so the bed
   leaves the map at the interior's slope (``_erosion_rate``).

Velocity re-solve policy (Blatter–Pattyn). Each step warm-starts the minimiser from the lattice
velocities of the previous step and calls ``blatter.solve`` with ``flow_rtol`` (default
``FLOW_RTOL`` = 1e-3) on the relative residual ‖∇E(u)‖/‖∇E(0)‖ (unbalanced force ÷ driving force):
when the previous velocities still meet it on the new geometry nothing is iterated (the check
costs a few energy evaluations), otherwise L-BFGS (with multigrid cycles on lattices of at least
2·``blatter.MG_MIN_NODES`` nodes along an axis) iterates until they do, at most ``flow_max_iter``
(``FLOW_MAX_ITER`` = 5000) iterations per step. A solve that ends above the tolerance (the cap,
or a stall) keeps the velocities it has, the next step goes on from them, and it counts as
unconverged (``FlowField.converged``, ``RunResult.unconverged``), which the outputs of a run
report. The energy rule of ``blatter.solve`` (``flow_energy_rtol``, ``FLOW_ENERGY_RTOL``) is off:
its estimate of the distance to the minimum ended warm-started solves after one or two cycles, at
residuals of 0.06–0.9 on the states below, and counted them as converged; the 2000-y Grindelwald
example (0.03 + 3e-3) ended 42 of its 43 solves above 0.03, at residuals up to 1.4.

Measured error (``bench/glacier_convergence.py``; relative L2 error of the velocity vectors over
the cells with more than 1 m of ice, each cell weighing the same, against a solve from the same
warm start to 1e-4; warm starts from a spin-up at 1e-2, default parameters, steps of 50 y),
surface / sliding, and the L-BFGS iterations of the solve to 1e-3:

============================  ===========  ===========  ===========  ===========  =====
state                          rtol 1e-2    rtol 3e-3    rtol 1e-3    energy rule  it.
============================  ===========  ===========  ===========  ===========  =====
Grindelwald 128² 46 m, 300 y   1.2 / 1.7 %  1.0 / 1.3 %  0.7 / 0.9 %  1.9 / 2.2 %  265
Grindelwald 128², 1000 y       1.6 / 1.7 %  1.4 / 1.5 %  1.0 / 1.2 %  2.3 / 2.4 %  547
Grindelwald 64², 300 y (*)     1.3 / 2.0 %  0.7 / 1.7 %  0.3 / 1.2 %               468
Ötztal 128 × 96, 300 y         3.0 / 4.4 %  2.8 / 4.1 %  2.2 / 3.1 %  3.5 / 4.7 %  205
Ötztal 128 × 96, 800 y         1.1 / 1.7 %  0.9 / 1.6 %  0.6 / 0.9 %  1.6 / 2.1 %  200
plateau 96² 250 m, 300 y       1.8 / 3.0 %  1.5 / 2.5 %  1.1 / 1.7 %  2.3 / 3.5 %  110
plateau 96², 1000 y            1.4 / 1.9 %  1.0 / 1.6 %  0.8 / 1.0 %  1.9 / 2.3 %  126
============================  ===========  ===========  ===========  ===========  =====

(*) against a solve to 1e-5, the lowest residual reached there (one to 1e-6 stalled at 4.5e-6
after 2000 iterations); the solve to 1e-4 lies 0.06 / 0.26 % from it. The sliding velocity
converges much more slowly than the residual, so ``FLOW_RTOL`` is the tightest tolerance within
reach of a prognostic run (1e-3: 6–9 times the iterations of 1e-2), and it still leaves the
sliding of the young Ötztal glaciers (cells of 64 × 93 m) 3.1 % off. The energy rule stopped
those solves after 2–6 iterations.

Domain: cells outside ``grid.valid`` hold no ice (what flows into them is lost, like ice
leaving through an open edge) and are never eroded; the bed there is filled with the nearest
valid elevation for the gradients. Edges: ``boundary`` ``"periodic"`` (wrapping) or ``"open"``
(stress-free edges for the flow, ice leaves through them).

Units: metres, years, m/y; the background inclination in radians. Nothing here reads or writes
files; inputs are never modified.
"""

from __future__ import annotations

import math
import time as clock
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from unerode_cli.glacier import blatter, erosion, massbalance, multiscale, sia, transport
from unerode_cli.grid import Grid
from unerode_cli.processes.parameters import check_on_grid

if TYPE_CHECKING:
    from unerode_cli.glacier.cnn_iceflow import CnnIceflow

#: Relative residual ‖∇E‖/‖∇E(0)‖ every prognostic solve must meet (module docstring: its measured
#: velocity error).
FLOW_RTOL = 1e-3
#: L-BFGS iterations allowed per step: a solve that needs more keeps the velocities it has and
#: counts as unconverged (measured warm solves to FLOW_RTOL took 110–550 iterations on the crops
#: of the module docstring, the first solve of the whole Grindelwald DEM 1215).
FLOW_MAX_ITER = 5000
#: The energy rule of ``blatter.solve`` (end a multigrid solve once its estimated distance to the
#: minimum of E is at most this fraction of |E|): off (0) by default, since it ended warm-started
#: solves at residuals of 0.06–1.6 (module docstring).
FLOW_ENERGY_RTOL = 0.0
#: Default CFL number c of the multi-scale local step δt (001 §5; ``_multiscale_cfl``).
MULTISCALE_CFL = transport.CFL
#: Multi-scale transport from an ice-free state: steps start at this length (y) and grow by
#: RAMP_FACTOR per step up to dt (``multiscale``: a cold start at a long dt can blow up).
RAMP_START = 10.0
RAMP_FACTOR = 1.5
#: Most explicit sub-steps in one step: a step that needs more stops before its first (``TooManySubsteps``).
MAX_SUBSTEPS = 100_000
#: Multi-scale steps that raise the ice surface above what the ice around could feed
#: (``surface_overshoot``) are taken again at half their length, down to this length (y).
RETRY_MIN_DT = 0.5
#: Surface rise (m) above the bound of ``surface_overshoot`` tolerated (rounding, the thin ice
#: the levels spread).
OVERSHOOT_TOLERANCE_M = 1.0

ICEFLOWS = ("blatter", "sia", "cnn")
TRANSPORTS = ("multiscale", "explicit")
BOUNDARIES = ("periodic", "open")

Ela = float | np.ndarray | Callable[[float], "float | np.ndarray"]


class UnstableStep(ValueError):
    """An explicit transport step above its stability limit while sub-steps are refused.

    Attributes: time (y) at the start of the step, dt (y) the step, stable (y) the limit.
    """

    def __init__(self, time: float, dt: float, stable: float) -> None:
        super().__init__(f"the explicit ice-transport step {dt:g} y at t = {time:g} y is above its "
                         f"stability limit {stable:.3g} y")
        self.time, self.dt, self.stable = time, dt, stable


class Diverged(FloatingPointError):
    """The ice thickness became infinite or NaN in a step (transport unstable at this dt)."""

    def __init__(self, time: float, dt: float) -> None:
        super().__init__(f"the ice thickness diverged in the step of {dt:g} y from t = {time:g} y")
        self.time, self.dt = time, dt


class TooManySubsteps(RuntimeError):
    """An explicit step would need more than ``MAX_SUBSTEPS`` sub-steps: the ice is far too fast
    for its stability limit (velocities that have blown up, or a dt of millennia)."""

    def __init__(self, time: float, dt: float, limit: float, speed: float) -> None:
        super().__init__(f"the step of {dt:g} y from t = {time:g} y needs more than {MAX_SUBSTEPS} "
                         f"explicit sub-steps (stable step {limit:.3g} y, the fastest ice at "
                         f"{speed:.3g} m/y)")
        self.time, self.dt, self.limit, self.speed = time, dt, limit, speed


@dataclass(frozen=True)
class CoupledParams:
    """Parameters of the coupled model (units in the module docstring).

    ``flow``: rheology, sliding and lattice (``blatter.FlowParams``; SIA uses A, n, ρ, g, C, σ).
    ``iceflow``: ``"blatter"``, ``"sia"`` or ``"cnn"`` (``cnn_iceflow``: a network trained on the fly
    predicts the Blatter–Pattyn velocities, refined and guarded to ``flow_rtol``; needs PyTorch);
    ``cnn``: that network (``cnn_iceflow.CnnIceflow``, its weights trained along the run: one object
    for all the steps of a run, shared by the copies ``dataclasses.replace`` makes), required with
    ``iceflow="cnn"`` and unused otherwise; left out of comparisons;
    ``transport``: ``"multiscale"`` or ``"explicit"``;
    ``allow_substeps``: cut unstable explicit steps into sub-steps (else ``UnstableStep``).
    ``beta`` (1/y), ``p_max`` (m/y): 001 Eq. 2, number or raster; ``snow_slope_min``,
    ``snow_slope_max`` (degrees): the surface slopes between which accumulation falls from all
    to none (``massbalance``). ``erosion``: erode the bed;
    ``k_e`` (m^(1−l)·y^(l−1)), ``abrasion_exponent`` l, ``k_q`` (1): 001 §6.1;
    ``adverse_slope_ratio`` ζ (1): no erosion on steeper adverse bed slopes (``erosion``).
    ``flow_rtol``, ``flow_max_iter``, ``flow_energy_rtol``: the velocity re-solve policy (module
    docstring). ``multiscale_cfl``: CFL number c of the multi-scale local step δt, in (0, 1]
    (001 §5: 0.1; ``_multiscale_cfl`` says when to lower it).
    """

    flow: blatter.FlowParams = field(default_factory=blatter.FlowParams)
    iceflow: str = "blatter"
    transport: str = "multiscale"
    allow_substeps: bool = True
    boundary: str = "open"
    background_slope: float = 0.0
    beta: float | np.ndarray = 1.0e-2
    p_max: float | np.ndarray = 2.0
    erosion: bool = True
    k_e: float | np.ndarray = 1.3e-7
    abrasion_exponent: float = 2.02
    k_q: float | np.ndarray = 3.2e-5
    adverse_slope_ratio: float = 1.5
    snow_slope_min: float = massbalance.SNOW_SLOPES[0]
    snow_slope_max: float = massbalance.SNOW_SLOPES[1]
    flow_rtol: float = FLOW_RTOL
    flow_max_iter: int = FLOW_MAX_ITER
    flow_energy_rtol: float = FLOW_ENERGY_RTOL
    multiscale_cfl: float = MULTISCALE_CFL
    edge_cells: np.ndarray | None = None
    cnn: CnnIceflow | None = field(default=None, compare=False, repr=False)

    def validate(self, shape: tuple[int, int]) -> None:
        """Raise ValueError (one sentence) for an unknown choice or a value out of range."""
        for name, value, known in (("iceflow", self.iceflow, ICEFLOWS),
                                   ("transport", self.transport, TRANSPORTS),
                                   ("boundary", self.boundary, BOUNDARIES)):
            if value not in known:
                raise ValueError(f"{name} must be one of {', '.join(known)}, got {value!r}")
        if self.iceflow == "cnn":
            from unerode_cli.glacier import cnn_iceflow

            cnn_iceflow.require_torch()
            cnn_iceflow.model_of(self)
        self.flow.validate(shape)
        for spec in (*massbalance.PARAMETERS, *erosion.PARAMETERS):
            if spec.name != "ela":
                check_on_grid(spec, getattr(self, spec.name), shape)
        if not (0.0 < self.flow_rtol < 1.0 and self.flow_max_iter >= 0
                and 0.0 <= self.flow_energy_rtol < 0.01):
            raise ValueError("flow_rtol must be in (0, 1), flow_max_iter ≥ 0 and flow_energy_rtol "
                             "in [0, 0.01)")
        if self.edge_cells is not None and np.shape(self.edge_cells) != tuple(shape):
            raise ValueError(f"the edge-cell mask must have the grid's shape {tuple(shape)}, "
                             f"got {np.shape(self.edge_cells)}")
        if not 0.0 < self.multiscale_cfl <= 1.0:
            raise ValueError(f"the multi-scale CFL number must be in (0, 1], got {self.multiscale_cfl:g}")
        if self.snow_slope_min > self.snow_slope_max:
            raise ValueError(f"snow_slope_min ({self.snow_slope_min:g}°) must not exceed "
                             f"snow_slope_max ({self.snow_slope_max:g}°)")
        if self.iceflow == "sia":
            if self.flow.sigma <= 1.0:
                raise ValueError("SIA sliding needs a sliding exponent σ > 1")
            if np.any(np.asarray(self.flow.sliding_c) <= 0.0):
                raise ValueError("SIA sliding needs a sliding coefficient C > 0 (inf: frozen bed)")


@dataclass(frozen=True)
class FlowField:
    """Ice velocities of one geometry, float64[ny, nx] each (m/y), 0 where there is no ice.

    ``mean``: column mean ū (001 Eq. 1); ``surface``; ``basal``: sliding velocity (001 §6.1).
    ``lattice``: the Blatter–Pattyn node velocities (u, v) float64[N+1, ny, nx] (the next warm
    start), None for SIA. ``iterations``, ``evaluations``: L-BFGS work of this solve (0 when the
    warm start was kept); ``residual``: ‖∇E‖/‖∇E(0)‖; ``energy``: E (Pa·m³/y); ``converged``.
    ``diffusivity``: SIA's D + H·|u_b|/|∇s| (m²/y) for its explicit stability, None for Blatter.
    ``takeover``: for a CNN solve in which the network predicted (``cnn_iceflow``), whether the
    converged solver took over from its refinement (True) or the refinement met the tolerance
    (False); None for any other solve (Blatter–Pattyn, SIA, or a geometry without driving stress).
    """

    mean: tuple[np.ndarray, np.ndarray]
    surface: tuple[np.ndarray, np.ndarray]
    basal: tuple[np.ndarray, np.ndarray]
    lattice: tuple[np.ndarray, np.ndarray] | None = None
    iterations: int = 0
    evaluations: int = 0
    residual: float = 0.0
    energy: float = 0.0
    converged: bool = True
    diffusivity: np.ndarray | None = None
    takeover: bool | None = None

    def max_speed(self) -> float:
        """Largest column-mean speed (m/y)."""
        return float(np.max(np.hypot(*self.mean))) if self.mean[0].size else 0.0


def sia_flow(bed: np.ndarray, thickness: np.ndarray, grid: Grid, flow: blatter.FlowParams,
             boundary: str = "open", background_slope: float = 0.0) -> FlowField:
    """SIA velocities (``sia.velocity``, no-slip deformation) plus Weertman sliding under the SIA
    basal drag τ_b = ρgH|∇s| = C·|u_b|^(σ−1) (001 Eq. 6 with the SIA stress), i.e.
    u_b = −(ρgH|∇s|/C)^(1/(σ−1))·∇s/|∇s| (m/y); frozen (0) where C = ∞. Needs σ > 1, C > 0."""
    h = np.asarray(thickness, dtype=np.float64)
    f = sia.velocity(bed, h, grid, flow.glen_a, flow.glen_n, flow.rho, flow.gravity, boundary=boundary,
                     background_slope=background_slope)
    sx, sy = sia.surface_gradient(np.asarray(bed, dtype=np.float64) + h, grid, boundary, background_slope)
    slope = np.hypot(sx, sy)
    c = np.broadcast_to(np.asarray(flow.sliding_c, dtype=np.float64), h.shape)
    tau = flow.rho * flow.gravity * h * slope
    with np.errstate(divide="ignore", invalid="ignore"):
        speed = np.where(np.isinf(c) | (h <= 0), 0.0, (tau / c) ** (1.0 / (flow.sigma - 1.0)))
        per_slope = np.divide(speed, slope, out=np.zeros_like(speed), where=(speed > 0) & (slope > 0))
    ub, vb = -per_slope * sx, -per_slope * sy
    sliding_d = h * per_slope  # H·|u_b|/|∇s|: the sliding flux −D_s·∇s
    return FlowField((f.u_mean + ub, f.v_mean + vb), (f.u_surface + ub, f.v_surface + vb), (ub, vb),
                     diffusivity=f.diffusivity + sliding_d)


def flow_field(bed: np.ndarray, thickness: np.ndarray, grid: Grid, params: CoupledParams,
               warm: tuple[np.ndarray, np.ndarray] | None = None, rtol: float | None = None,
               max_iter: int | None = None, energy_rtol: float | None = None) -> FlowField:
    """Velocities of the geometry (b, H) with ``params.iceflow``; Blatter–Pattyn warm-started
    from ``warm`` (lattice velocities) to the residual ``rtol`` (default ``params.flow_rtol``) or
    the energy rule ``energy_rtol`` (default ``params.flow_energy_rtol``; 0: residual only); with
    ``"cnn"`` the run's network predicts the warm start instead (``cnn_iceflow.CnnIceflow.solve``:
    refinement, then ``blatter.solve`` to ``rtol`` when the refinement misses it; ``takeover``
    says which gave the velocities)."""
    if params.iceflow == "sia":
        return sia_flow(bed, thickness, grid, params.flow, params.boundary, params.background_slope)
    solve, model = blatter.solve, None
    if params.iceflow == "cnn":  # the network of this run (``params.cnn``), then blatter.solve
        from unerode_cli.glacier import cnn_iceflow

        model = cnn_iceflow.model_of(params)
        solve = model.solve
    sol = solve(bed, thickness, grid, params.flow, boundary=params.boundary,
                background_slope=params.background_slope, initial=warm,
                rtol=params.flow_rtol if rtol is None else rtol,
                max_iter=params.flow_max_iter if max_iter is None else max_iter,
                energy_rtol=params.flow_energy_rtol if energy_rtol is None else energy_rtol)
    takeover = None if model is None or model.last is None else model.last.takeover
    return FlowField(sol.mean_velocity(), sol.surface_velocity(), sol.basal_velocity(), (sol.u, sol.v),
                     sol.iterations, sol.evaluations, sol.residual, sol.energy, sol.converged,
                     takeover=takeover)


@dataclass(frozen=True)
class GlacierState:
    """Bed b and ice thickness H (float64[ny, nx], m) at ``time`` (y), and the lattice velocities
    of the last Blatter–Pattyn solve (the next warm start; None at a cold start or with SIA)."""

    bed: np.ndarray
    thickness: np.ndarray
    time: float = 0.0
    lattice: tuple[np.ndarray, np.ndarray] | None = None


@dataclass(frozen=True)
class StepReport:
    """What one step did: ``time`` (y) at its end, ``dt`` (y), ice ``volume`` (m³) at its end,
    the ``flow`` of its start geometry, ``substeps`` of explicit transport (1 for multi-scale),
    ``eroded`` volume of bedrock removed (m³, ≥ 0); wall-clock seconds spent on the ice flow
    (``flow_seconds``) and on the rest of the step (``transport_seconds``: mass balance, transport,
    erosion)."""

    time: float
    dt: float
    volume: float
    flow: FlowField
    substeps: int
    eroded: float
    flow_seconds: float = 0.0
    transport_seconds: float = 0.0


def ice_volume(thickness: np.ndarray, grid: Grid) -> float:
    """Σ H·dx·dy over the domain (m³)."""
    return float(np.sum(thickness, where=grid.valid)) * grid.cell_area


def fill_outside(bed: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """The bed with every cell outside ``valid`` set to its nearest valid cell's elevation (m)."""
    bed = np.asarray(bed, dtype=np.float64)
    if valid.all():
        return bed
    from scipy import ndimage

    index = ndimage.distance_transform_edt(~valid, return_distances=False, return_indices=True)
    return bed[tuple(index)]


def ela_at(ela: Ela, time: float) -> float | np.ndarray:
    """E (m) at ``time`` (y): the value itself, or ``ela(time)`` for a function of time."""
    return ela(time) if callable(ela) else ela


@dataclass(frozen=True)
class ElaTable:
    """E(t) (m) interpolated linearly in a table of times (y, strictly increasing) and values
    (m), held constant beyond its ends; call it with a time (y)."""

    times: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        t, e = np.asarray(self.times, dtype=np.float64), np.asarray(self.values, dtype=np.float64)
        if t.ndim != 1 or t.shape != e.shape or t.size == 0 or np.any(np.diff(t) <= 0):
            raise ValueError("an ELA table needs one value per time and strictly increasing times")
        if not (np.isfinite(t).all() and np.isfinite(e).all()):
            raise ValueError("an ELA table needs finite times and values")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", e)

    def __call__(self, time: float) -> float:
        return float(np.interp(time, self.times, self.values))


def never_glaciated(bed: np.ndarray, thickness: np.ndarray, grid: Grid, ela: Ela) -> bool:
    """Whether no ice can ever form: no ice now and the bed at or below E everywhere at all times
    (then M ≤ 0 everywhere, 001 Eq. 2, and the bed never changes). E a number, a raster or an
    ``ElaTable`` (its lowest value); False for any other function of time."""
    if np.any(np.asarray(thickness)[grid.valid] > 0):
        return False
    if isinstance(ela, ElaTable):
        lowest: float | np.ndarray = float(ela.values.min())
    elif callable(ela):
        return False
    else:
        lowest = np.broadcast_to(np.asarray(ela, dtype=np.float64), grid.shape)[grid.valid]
    return bool(np.all(np.asarray(bed)[grid.valid] <= lowest))


def _mass_balance(state: GlacierState, grid: Grid, params: CoupledParams, ela: Ela) -> np.ndarray:
    surface = state.bed + state.thickness
    m = massbalance.mass_balance(surface, ela_at(ela, state.time), params.beta, params.p_max,
                                 massbalance.surface_slope(surface, grid.dx, grid.dy),
                                 (params.snow_slope_min, params.snow_slope_max))
    return np.where(grid.valid, m, 0.0)


def _explicit_limit(flow: FlowField, grid: Grid) -> float:
    """Stable explicit step (y): the CFL limit (001 §5, c = 0.1) and, for SIA, the diffusion one."""
    limit = transport.max_stable_dt(*flow.mean, grid)
    if flow.diffusivity is not None:
        limit = min(limit, sia.max_stable_dt(flow.diffusivity, grid))
    return limit


def _multiscale_cfl(flow: FlowField, grid: Grid, c: float) -> float:
    """CFL number of the multi-scale local step δt: ``c`` (``CoupledParams.multiscale_cfl``) for
    Blatter–Pattyn velocities; for SIA lowered so that the finest level also respects the explicit
    diffusion limit of its nonlinear diffusivity.

    When to lower c below 001's 0.1: Blatter–Pattyn velocities are solved once per step and held
    while the ice moves, and the flux they carry answers to the surface they were solved on. Under
    thick ice a one-cell groove fills faster than the CFL step allows for: in an 800 m slab on a
    0.5° slope (250 m cells, up to 94 m/y) a 100 m groove gains 177 m/y, so held velocities
    overfill it within a year (to +80 m after 1 y of explicit steps of 0.01 y), and one
    multi-scale step leaves a wave train beside it whose amplitude grows with c: +129/−118 m at
    c = 0.1, +65/−58 m at 0.05 (``tests/glacier/test_glacier_coupled_cfl.py``). Under the ice sheet
    of 001 Fig. 6 at 256² (250 m cells, 73.65 ky, 1144 km³ of ice up to 1.3 km thick, 50-year
    steps over 1000 years): at c = 0.1 such grooves and ridges kept 52–160 cells of thick ice 50 m
    off their neighbours' mean, steps moved a surface by 200–790 m, the fastest thick ice reached
    1.4–24 km/y, 3 steps were rejected and a solve took 24–40 L-BFGS iterations; the run diverged
    at 75.55 ky (a crater in the ice that the ice entered at 60 km/y, eroding the bed to −6.8 km).
    At c = 0.05: 16–42 cells, at most 104 m per step, the fastest thick ice 1.4 km/y, no rejected
    step and 12 iterations a solve (the warm start is closer), a third of the cost per step.

    Why 0.1 stays the default: where the ice moves, a step of half the c takes it half as far
    towards its steady state. On the growing valley glacier of
    ``tests/glacier/test_fig14_coupling.py`` (30 × 45 cells of 100 m, erosion off) the ice volume at
    the glacial maximum is 0.312 km³ in 5-year steps; in 50-year steps 0.290 km³ at c = 0.1
    (−7 %) against 0.264 km³ at 0.05 (−15 %), with the thickest ice 116 m against 85 m (113 m in
    5-year steps); in 10-year steps 0.311 against 0.303 km³. With 0.05 as the default and
    erosion on, that glacier's thickest ice fell from 155 to 85 m (50-year steps); the
    SIA tongue of ``test_the_held_bed_is_not_eroded_and_the_rest_erodes_as_before`` (20-year steps,
    2000 y) reached 120 m at the map's edge instead of more than 150; the Blatter valley of
    ``tests/cli/test_glaciate_command.py`` (50-year steps, 1000 y) kept a V (b = 1.10, 1.48–1.66
    at 0.1). So valley glaciers, the common case, keep 001's 0.1, and runs through a glacial
    maximum set ``--transport-cfl 0.05`` (the Fig. 6 and Grindelwald pipelines do), which the
    message of a diverged run suggests. On Grindelwald at 92 m through the last glacial cycle
    (LR04, 50-year steps) 0.1 grew the one-cell roughness under 2–2.5 km of ice on the firn
    plateau, abraded a basin 2.7 km deep and, at 63.75 ka, the velocities went 1.0 → 2.7 → 15 →
    78 km/y in four steps while a fifth of the ice left the map; the same steps from a checkpoint
    at 0.05 calmed to 0.3 km/y, and the cycle at 0.05 ran to its end with no rejected step."""
    if flow.diffusivity is None:
        return c
    cfl_limit = transport.max_stable_dt(*flow.mean, grid)
    if not (0.0 < cfl_limit < math.inf):
        return c
    return c * min(1.0, sia.max_stable_dt(flow.diffusivity, grid) / cfl_limit)


def _erosion_rate(bed: np.ndarray, thickness: np.ndarray, flow: FlowField, grid: Grid,
                  params: CoupledParams) -> np.ndarray:
    """Abrasion + quarrying (m/y, ≤ 0) under the sliding ice (001 §6.1), 0 outside the domain.

    A cell of ``params.edge_cells`` (the map's open edges and nodata borders) takes the rate of the
    nearest cell that is not one (``edge_follows_interior``): the bed keeps its slope across the
    edge, as if the terrain went on beyond the map. An edge cell eroded by its own sliding speed
    would run away — lowering the edge lowers the ice surface there, the ice leaving the map
    speeds up and cuts the edge faster (in 001 Fig. 6 at 256², an outlet's edge cell fell by
    1.8 km) — and an edge held fixed is a sill that the cells behind it deepen against, an
    over-deepening made by the map's frame."""
    abrasion, quarrying = erosion.erosion_rates(bed, *flow.basal, grid, params.k_e, params.abrasion_exponent,
                                                params.k_q, params.boundary, surface=bed + thickness,
                                                adverse_slope_ratio=params.adverse_slope_ratio)
    rate = np.where(grid.valid, abrasion + quarrying, 0.0)
    if params.edge_cells is None:
        return rate
    return edge_follows_interior(rate, grid.valid, params.edge_cells)


def edge_follows_interior(rate: np.ndarray, valid: np.ndarray, edge: np.ndarray) -> np.ndarray:
    """``rate`` (float[ny, nx]) with each valid cell of ``edge`` (bool[ny, nx]) given the value of
    the nearest valid cell outside ``edge`` (Euclidean distance in cells; ties broken by scipy's
    ``distance_transform_edt``), 0 outside ``valid``; unchanged where no such cell exists."""
    from scipy import ndimage

    interior = valid & ~edge
    if not interior.any():
        return np.where(valid, rate, 0.0)
    rows, cols = ndimage.distance_transform_edt(~interior, return_distances=False, return_indices=True)
    return np.where(valid, rate[rows, cols], 0.0)


def step(state: GlacierState, grid: Grid, params: CoupledParams, ela: Ela, dt: float) -> tuple[
        GlacierState, StepReport]:
    """One coupled step of length dt (y) (module docstring); returns the new state and a report.

    ``state.bed`` must be finite everywhere (``fill_outside``). Raises ``UnstableStep`` for an
    explicit step above its stability limit when ``params.allow_substeps`` is False, and
    ``Diverged`` when the thickness blows up (multi-scale steps too long for SIA's diffusion).
    """
    if not (dt > 0 and math.isfinite(dt)):
        raise ValueError(f"the time step must be finite and > 0, got {dt} y")
    valid = grid.valid
    h = np.where(valid, state.thickness, 0.0)
    state = replace(state, thickness=h)
    start = clock.perf_counter()
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # a blow-up: Diverged below
        flow = flow_field(state.bed, h, grid, params, warm=state.lattice)
        flow_done = clock.perf_counter()
        substeps = 1
        if params.transport == "multiscale":
            h_new = multiscale.step(h, *flow.mean, _mass_balance(state, grid, params, ela), grid, dt,
                                    params.boundary, c=_multiscale_cfl(flow, grid, params.multiscale_cfl))
            change = dt * _erosion_rate(state.bed, h, flow, grid, params) if params.erosion else 0.0
        else:
            h_new, change, substeps = _explicit(state, flow, grid, params, ela, dt)
        h_new = np.where(valid, h_new, 0.0)
    if not (np.isfinite(h_new).all() and np.isfinite(change).all()):
        raise Diverged(state.time, dt)
    bed = state.bed + change
    eroded = -float(np.sum(change)) * grid.cell_area if params.erosion else 0.0
    new = GlacierState(bed, h_new, state.time + dt, flow.lattice)
    return new, StepReport(new.time, dt, ice_volume(h_new, grid), flow, substeps, eroded,
                           flow_done - start, clock.perf_counter() - flow_done)


def surface_overshoot(before: GlacierState, after: GlacierState, grid: Grid, params: CoupledParams,
                      dt: float) -> float:
    """How far (m) a step raised the ice surface s = b + H of some cell above the highest surface
    of the state before it within reach, plus the most the mass balance may add, p_max·dt; ≤ 0
    for a step that keeps to it.

    Ice flows down its surface gradient, so ∂s/∂t = M − ∇·(ūH) obeys a maximum principle: ice
    brought by the flow never stands higher than the ice it came from. The reach is the support
    of the coarsest level of the multi-scale transport (2^n cells each way, ``multiscale``), the
    farthest a step can move ice. A step that breaks this bound has created ice: 001 §5's level
    weights vary in space, so where fast ice (tiny δt) borders still ice, the coarse levels carry
    the fast ice's convergence to the still cells, whose δt is long. On Grindelwald at 92 m under
    the ice of 86 ka (thick ice at km/y against the map's east edge), one 50-year step put a
    2.3 km spike of ice on an empty cell 10 cells away, and the run diverged in the next.
    """
    from scipy import ndimage

    reach = 2 ** multiscale.level_count(grid.shape)
    old = np.where(grid.valid, before.bed + before.thickness, -np.inf)
    highest = ndimage.maximum_filter(old, size=2 * reach + 1, mode="nearest")
    rise = np.where(grid.valid, after.bed + after.thickness - highest, -np.inf)
    return float(rise.max()) - float(np.max(params.p_max)) * dt


def _explicit(state: GlacierState, flow: FlowField, grid: Grid, params: CoupledParams, ela: Ela,
              dt: float) -> tuple[np.ndarray, np.ndarray | float, int]:
    """Explicit transport over dt in sub-steps within the stability limit; SIA velocities are
    re-evaluated every sub-step, Blatter–Pattyn ones held for the step. Returns (H, Δb, count)."""
    limit = _explicit_limit(flow, grid)
    if dt > limit * (1.0 + 1e-12) and not params.allow_substeps:
        raise UnstableStep(state.time, dt, limit)
    h, change, done, count = state.thickness, 0.0, 0.0, 0
    sub_state = state
    while done < dt:
        if count:
            if params.iceflow == "sia":
                flow = flow_field(state.bed, h, grid, params)
            sub_state = replace(state, thickness=h, time=state.time + done)
            limit = _explicit_limit(flow, grid)
        if dt - done > limit * (MAX_SUBSTEPS - count):
            raise TooManySubsteps(state.time, dt, limit, float(np.max(np.hypot(*flow.mean))))
        sub = min(dt - done, limit)
        if dt - done - sub < 1e-9 * dt:
            sub = dt - done
        m = _mass_balance(sub_state, grid, params, ela)
        h = np.where(grid.valid, transport.step(h, *flow.mean, m, grid, sub, params.boundary), 0.0)
        if params.erosion:
            change = change + sub * _erosion_rate(state.bed, state.thickness, flow, grid, params)
        done += sub
        count += 1
    return h, change, count


def step_times(duration: float, dt: float, stops: Sequence[float] = ()) -> np.ndarray:
    """End times (y) of the steps of a run of ``duration`` with steps of ``dt``, every time in
    ``stops`` (e.g. snapshot times) being the end of a step."""
    if not (duration > 0 and dt > 0 and math.isfinite(duration) and math.isfinite(dt)):
        raise ValueError(f"duration and dt must be finite and > 0, got {duration} y and {dt} y")
    targets = sorted({float(s) for s in stops if 0.0 < s < duration}) + [float(duration)]
    out: list[float] = []
    t = 0.0
    for target in targets:
        while t < target:
            end = t + dt
            if end >= target - 1e-9 * dt:
                end = target
            out.append(end)
            t = end
    return np.array(out)


class Stopwatch:
    """Adds the wall-clock seconds since the last lap (or its creation) to ``totals[name]``."""

    def __init__(self, totals: dict[str, float]) -> None:
        self.totals = totals
        self.last = clock.perf_counter()

    def lap(self, name: str) -> None:
        now = clock.perf_counter()
        self.totals[name] += now - self.last
        self.last = now


#: The parts of a run's wall-clock time in ``RunResult.seconds``.
WALL_TIME_PARTS = ("ice_flow", "transport_erosion", "ice_free", "other")


@dataclass
class RunResult:
    """A run: the final ``state``, the ice-volume series (``times`` y, ``volumes`` m³, from t = 0,
    one entry per step taken), and totals: ``steps``, ``substeps`` (explicit transport),
    ``solves`` (Blatter–Pattyn velocity solves of the accepted steps), ``resolves`` (those whose
    velocities were iterated), ``iterations`` (their L-BFGS iterations), ``evaluations`` (L-BFGS
    energy evaluations), ``unconverged`` (solves that ended above their tolerance ``flow_rtol``:
    iteration cap or stall), ``max_residual``, ``eroded`` (m³ of bedrock removed by the
    glaciers), ``retries`` (multi-scale steps taken again at half their
    length, ``surface_overshoot``), ``cnn_solves`` (solves of ``iceflow="cnn"`` in which the
    network predicted, ``FlowField.takeover`` not None) and ``cnn_takeovers`` (those of them that
    the converged solver finished), and ``seconds``: wall-clock time by part of the loop
    (``WALL_TIME_PARTS``: the ice flow, transport with mass balance and erosion, the processes of
    ice-free ground, and the rest: the checks and callbacks of ``run``). ``cap`` (y): the longest
    next step the ramp and the rejected steps allow (``Stepping``), kept so that a run continued
    from this result (a checkpoint) takes the steps an uninterrupted one would."""

    state: GlacierState
    times: list[float]
    volumes: list[float]
    steps: int = 0
    substeps: int = 0
    solves: int = 0
    resolves: int = 0
    iterations: int = 0
    evaluations: int = 0
    unconverged: int = 0
    max_residual: float = 0.0
    eroded: float = 0.0
    retries: int = 0
    cnn_solves: int = 0
    cnn_takeovers: int = 0
    seconds: dict[str, float] = field(default_factory=lambda: dict.fromkeys(WALL_TIME_PARTS, 0.0))
    cap: float = math.inf

    def add(self, state: GlacierState, report: StepReport) -> None:
        flow = report.flow
        self.state = state
        self.times.append(state.time)
        self.volumes.append(report.volume)
        self.steps += 1
        self.substeps += report.substeps
        self.solves += flow.lattice is not None
        self.resolves += flow.iterations > 0
        self.iterations += flow.iterations
        self.evaluations += flow.evaluations
        self.unconverged += not flow.converged
        self.max_residual = max(self.max_residual, flow.residual)
        self.eroded += report.eroded
        self.cnn_solves += flow.takeover is not None
        self.cnn_takeovers += bool(flow.takeover)
        self.seconds["ice_flow"] += report.flow_seconds
        self.seconds["transport_erosion"] += report.transport_seconds

    @property
    def cnn_met(self) -> int:
        """Solves of ``iceflow="cnn"`` whose prediction and refinement met ``flow_rtol`` alone."""
        return self.cnn_solves - self.cnn_takeovers

    def saved(self) -> dict[str, Any]:
        """The run as NumPy arrays (bed, ice, the last lattice velocities: ``lattice_u``,
        ``lattice_v``, empty for none) and numbers, lists and mappings of them (the time, the
        volume series, the totals with the step cap, the wall-time parts): what a checkpoint
        keeps, every float exact; ``restored`` takes it back."""
        state = self.state
        lattice = state.lattice if state.lattice is not None else (np.zeros(0), np.zeros(0))
        return {"bed": state.bed, "thickness": state.thickness, "time": state.time,
                "lattice_u": lattice[0], "lattice_v": lattice[1], "series_times": list(self.times),
                "series_volumes": list(self.volumes),
                "totals": {name: getattr(self, name) for name in _RESULT_TOTALS},
                "seconds": dict(self.seconds)}

    @classmethod
    def restored(cls, saved: dict[str, Any]) -> RunResult:
        """The run that ``saved`` gave (extra keys are ignored)."""
        lattice = (saved["lattice_u"], saved["lattice_v"]) if np.size(saved["lattice_u"]) else None
        state = GlacierState(np.asarray(saved["bed"]), np.asarray(saved["thickness"]), float(saved["time"]),
                             lattice)
        seconds = {**dict.fromkeys(WALL_TIME_PARTS, 0.0), **saved["seconds"]}
        return cls(state, list(map(float, saved["series_times"])), list(map(float, saved["series_volumes"])),
                   seconds=seconds, **saved["totals"])


#: The totals of a ``RunResult`` that ``RunResult.saved`` keeps (besides ``seconds``).
_RESULT_TOTALS = ("steps", "substeps", "solves", "resolves", "iterations", "evaluations", "unconverged",
                  "max_residual", "eroded", "retries", "cnn_solves", "cnn_takeovers", "cap")


class Stepping:
    """A coupled run as a sequence of accepted steps towards the end ``times`` (y, increasing,
    e.g. ``step_times``): ``advance`` takes the next one; the caller owns the loop (``run``, or
    a job's stepping loop with checkpoints).

    Cold starts: with multi-scale transport, whenever a step starts without ice, the steps are
    cut to ``RAMP_START`` years and grow by ``RAMP_FACTOR`` per step until they reach the times
    asked (``multiscale``: laying a long step of accumulation at once leaves a steep edge that
    can blow up). Rejected steps: a multi-scale step that creates ice (``surface_overshoot``) is
    thrown away and taken again at half its length (not below ``RETRY_MIN_DT``), and the steps
    then grow back by ``RAMP_FACTOR`` per step. Every accepted step enters the volume series.
    ``after(state, dt)``, when given, follows every accepted glacier step of length dt with other
    processes and returns the state they leave (``cycle.IceFreeErosion``).

    ``result``: a run to continue (from a checkpoint: ``state`` is its ``result.state``); its
    series, totals and step cap (``RunResult.cap``) go on, so the steps are those an
    uninterrupted run takes. ``state`` is the state reached, ``result`` the run so far."""

    def __init__(self, state: GlacierState, grid: Grid, params: CoupledParams, ela: Ela,
                 times: Sequence[float], after: Callable[[GlacierState, float], GlacierState] | None = None,
                 result: RunResult | None = None) -> None:
        params.validate(grid.shape)
        self.grid, self.params, self.ela, self.after = grid, params, ela, after
        self.times = [float(end) for end in times]
        self.state = state
        self.result = result if result is not None else RunResult(
            state, [state.time], [ice_volume(state.thickness, grid)])
        self.ramp = params.transport == "multiscale"

    def next_end(self) -> float | None:
        """The end time (y) the next step goes towards: the first of ``times`` after the state's
        time; None when the run has reached the last."""
        for end in self.times:
            if self.state.time < end:
                return end
        return None

    @property
    def finished(self) -> bool:
        """Whether the state has reached the last of ``times``."""
        return self.next_end() is None

    def advance(self) -> StepReport:
        """Take the next accepted step (rejected ones taken again shorter first) towards
        ``next_end``, then ``after``; the state ends exactly on that end time when the step
        reaches it. Returns the accepted step's report; ValueError when the run is finished."""
        end = self.next_end()
        if end is None:
            raise ValueError(f"the run has reached its end, t = {self.state.time:g} y")
        grid, params, result, state = self.grid, self.params, self.result, self.state
        cap = result.cap
        while True:
            if self.ramp and not np.any(state.thickness[grid.valid] > 0):
                cap = RAMP_START
            length = min(end - state.time, cap)
            if end - state.time - length <= 1e-9 * length:
                length = end - state.time
            new, report = step(state, grid, params, self.ela, length)
            if not (self.ramp and length > RETRY_MIN_DT
                    and surface_overshoot(state, new, grid, params, length) > OVERSHOOT_TOLERANCE_M):
                break
            cap = 0.5 * length
            result.retries += 1
        state = new
        if self.after is not None:
            lap = Stopwatch(result.seconds)
            state = self.after(state, length)
            lap.lap("ice_free")
        if state.time >= end - 1e-9 * length:
            state = replace(state, time=end)
        result.add(state, report)
        cap *= RAMP_FACTOR
        result.cap = cap
        self.state = state
        return report


def run(state: GlacierState, grid: Grid, params: CoupledParams, ela: Ela, times: Sequence[float],
        on_step: Callable[[GlacierState, StepReport], None] | None = None,
        check: Callable[[GlacierState, StepReport, int], bool | None] | None = None,
        after: Callable[[GlacierState, float], GlacierState] | None = None,
        result: RunResult | None = None) -> RunResult:
    """Step ``state`` to each of the end ``times`` (y, increasing, e.g. ``step_times``) in turn
    (``Stepping``: cold-start ramp, rejected steps, ``after``), calling ``on_step(new_state,
    report)`` at each of them (progress, snapshots), and ``check(new_state, report, k)`` after
    every step k (1, 2, …) taken, ramp steps included (e.g. a divergence guard that raises, so
    that a run stops at the step where it diverges); when ``check`` returns True the run ends
    there (e.g. cancelled, or a step budget spent), and the result holds the steps taken so far.
    ``result``: a run to continue (``Stepping``)."""
    started = clock.perf_counter()
    stepping = Stepping(state, grid, params, ela, times, after, result)
    result = stepping.result
    timed_before = sum(result.seconds.values())
    report: StepReport | None = None
    for end in stepping.times:
        stop = False
        while stepping.state.time < end and not stop:
            report = stepping.advance()
            stop = check is not None and bool(check(stepping.state, report, result.steps))
        if stop:
            break
        if on_step is not None and report is not None:
            on_step(stepping.state, report)
    timed = sum(result.seconds.values()) - timed_before
    result.seconds["other"] += clock.perf_counter() - started - timed
    return result
