"""Registry of surface processes the runner can drive, each bound to a terrain's grid and
boundaries. A process's parameter declarations (``PARAMETERS``) feed CLI options, validation
and provenance."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.errors import InputError, RunFailure
from unerode_cli.io.inflow_files import read_inflow
from unerode_cli.io.parameter_file import read_parameter_file
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes import debris, fluvial, fluvial_implicit, hillslope, thermal, thermal_ca
from unerode_cli.processes.budget import MassBudget
from unerode_cli.processes.inflow import InflowHistory
from unerode_cli.processes.parameters import UPLIFT, ParamSpec
from unerode_cli.run.boundaries import Boundaries
from unerode_cli.run.runner import MAX_SUBSTEPS, Change, Process, substeps_needed


@dataclass
class Surface:
    """The terrain and boundaries a process runs on, with the flow routing of the last
    elevation asked for (recomputed when the elevation changes)."""

    terrain: Terrain
    boundaries: Boundaries
    method: str = "mfd"
    _cached: tuple[tuple[tuple[int, ...], int], Any] | None = field(default=None, repr=False)
    _fixed_outlets: np.ndarray | None = field(default=None, repr=False)

    def outlets(self, h: np.ndarray) -> np.ndarray:
        """bool[ny, nx] base-level cells of ``h`` (edges, sea, Dirichlet nodes). Without a sea
        level they do not depend on ``h``: that mask is built once and handed out read-only."""
        if self.boundaries.sea_level is not None:
            return self.boundaries.outlets(h, self.terrain)
        if self._fixed_outlets is None:
            mask = self.boundaries.outlets(h, self.terrain)
            mask.flags.writeable = False
            self._fixed_outlets = mask
        return self._fixed_outlets

    def release(self) -> None:
        """Drop the kept routing."""
        self._cached = None

    def holds(self, key: tuple[tuple[int, ...], int]) -> bool:
        """Whether the kept routing is that of the elevation whose fingerprint is ``key``
        (``hydro.routing.fingerprint``)."""
        return self._cached is not None and self._cached[0] == key

    def routing(self, h: np.ndarray, key: tuple[tuple[int, ...], int] | None = None) -> Any:
        """The routing of ``h`` towards its outlets (``unerode_cli.hydro.Routing``), kept for
        as long as ``h`` holds the same values bit for bit (NaN on nodata included), as told by
        a fingerprint of its values (``hydro.routing.fingerprint``: no copy of ``h`` is kept);
        ``key``: that fingerprint when the caller has it already."""
        from unerode_cli.hydro.routing import fingerprint, release_scratch, route

        key = fingerprint(h) if key is None else key
        if self.holds(key):
            return self._cached[1]  # type: ignore[index]
        self._cached = None   # the old routing's arrays go before the new ones are made
        routing = route(h, self.terrain.grid, self.outlets(h), self.method)
        # the flood's work arrays (about 6 bytes a cell) would outlive it until the next routing
        release_scratch("flood.")
        self._cached = (key, routing)
        return routing


def _change(dh: np.ndarray, budget: MassBudget) -> Change:
    return Change(dh, budget.eroded, budget.deposited, budget.outflux, budget.inflow)


#: ``"auto"`` runs implicit where the explicit scheme would need more sub-steps a step than
#: this (without deposition, with it): the cost of one implicit step in explicit sub-steps,
#: measured at 1024² and 2048² (bench/fluvial_implicit.py, docs/erode.md): 1.3–2 without
#: deposition (one pass), 1.5–4 with it (3–6 pairs of passes; MFD the dearer).
AUTO_SUBSTEPS = {False: 2, True: 4}


def implicit_layout(cells: int) -> str:
    """The implicit step's layout (``fluvial_implicit.step``): the faster ``"ordered"`` where
    its extra bytes fit in what the run may still allocate, else ``"lean"``."""
    from unerode_cli.run.memory import headroom_bytes

    extra = float(cells) * fluvial_implicit.ORDERED_EXTRA_BYTES_PER_CELL
    return "ordered" if extra <= headroom_bytes() else "lean"


@dataclass
class FluvialProcess:
    """Fluvial erosion/deposition (000 §3).

    Forward steps are ``forward``: ``"implicit"`` (``fluvial_implicit``, stable at any dt, so
    never sub-stepped), ``"explicit"`` (``fluvial.step``, sub-stepped to its CFL bound), or
    ``"auto"``: on the first forward step, implicit where the explicit scheme would need more
    sub-steps than an implicit step costs (:data:`AUTO_SUBSTEPS`), else explicit, kept for the
    whole run (``chosen``); backward steps are explicit with the slope ``scheme``. The explicit
    stability check computes the step itself and reads the CFL bound off its discharge; the step is kept, so
    that ``advance`` with the same elevation and dt (no sub-steps, the usual case) costs
    nothing more. A step that needs sub-steps wastes that one step. ``inflow``: rivers entering
    the map (000 §6.3.1), or None. ``passes`` counts the passes of the implicit steps'
    deposition iteration, which starts from the previous step's deposition rates.
    """

    surface: Surface
    params: fluvial.FluvialParams
    scheme: str = "limiter"
    inflow: fluvial.Inflow | None = None
    forward: str = "explicit"
    name: str = "fluvial"
    passes: int = 0
    chosen: str | None = None
    _last: tuple[Any, float, fluvial.FluvialChange] | None = field(default=None, repr=False)
    _deposition: np.ndarray | None = field(default=None, repr=False)
    _checked: bool = field(default=False, repr=False)

    def _implicit(self, dt: float) -> bool:
        return dt > 0.0 and (self.forward if self.forward != "auto" else self.chosen) == "implicit"

    def _choose(self, elevation: np.ndarray, dt: float) -> None:
        """Settle ``"auto"`` on the first forward step from the explicit scheme's sub-steps,
        read off the CFL bound of the precipitation's discharge (no step is computed); implicit
        too where the explicit step's arrays would not fit in the memory available."""
        from unerode_cli.run.memory import COMMAND_BYTES_PER_CELL, available_bytes

        routing = self.surface.routing(elevation)
        stable = fluvial.max_stable_dt(elevation, self.surface.terrain.grid, self.params, routing,
                                       validated=self._checked)
        self._checked = True
        depositing = bool(np.any(np.asarray(self.params.k_d) > 0.0))
        needed = substeps_needed(dt, stable) if stable > 0.0 else MAX_SUBSTEPS + 1
        explicit_bytes = float(elevation.size) * COMMAND_BYTES_PER_CELL["erode explicit"]
        fits = explicit_bytes <= available_bytes()
        self.chosen = "implicit" if needed > AUTO_SUBSTEPS[depositing] or not fits else "explicit"

    def _step(self, elevation: np.ndarray, dt: float) -> tuple[Any, fluvial.FluvialChange]:
        # The surface hands out the same routing object as long as the elevation is unchanged,
        # so it keys the kept step too; a kept step of another elevation goes first, with its
        # routing, before the new ones are made.
        from unerode_cli.hydro.routing import fingerprint

        key = fingerprint(elevation)
        if self._last is not None and not self.surface.holds(key):
            self._last = None
        routing = self.surface.routing(elevation, key)
        last = self._last
        if last is not None and last[0] is routing and last[1] == dt:
            return routing, last[2]
        self._last = last = None   # its arrays go before the new step's are made
        # the parameters (frozen) are checked on the first step; later steps skip that scan
        grid = self.surface.terrain.grid
        if self._implicit(dt):
            change = self._implicit_step(elevation, dt, routing, self._checked)
        else:
            change = fluvial.step(elevation, grid, routing.outlets, self.params, dt, routing=routing,
                                  scheme=self.scheme, inflow=self.inflow, validated=self._checked)
        self._checked = True
        self._last = (routing, dt, change)
        return routing, change

    def _implicit_step(self, elevation: np.ndarray, dt: float, routing: Any, validated: bool,
                       depth: int = 0) -> fluvial.FluvialChange:
        """An implicit step; one whose deposition iteration does not converge is done again
        as two half steps (each routed anew), down to 1/256 of it."""
        grid = self.surface.terrain.grid
        done = fluvial_implicit.step(elevation, grid, routing.outlets, self.params, dt,
                                     routing=routing, inflow=self.inflow, validated=validated,
                                     deposition=self._deposition, layout=implicit_layout(grid.valid.size))
        self.passes += done.passes
        self._deposition = done.deposition
        if done.converged or depth == 8:
            if not done.converged:
                raise RunFailure(f"the implicit fluvial step did not converge (deposition still "
                                 f"changing by {done.residual:.3g}× its tolerance after "
                                 f"{done.passes} passes at a step of {dt:g} years).")
            return done.change
        half = 0.5 * dt
        first = self._implicit_step(elevation, half, routing, True, depth + 1)
        middle = elevation + first.dh
        second = self._implicit_step(middle, half, self.surface.routing(middle), True, depth + 1)
        return _joined(first, second, half)

    def release(self) -> None:
        """Drop the kept step and routing (the run is over); the counts stay."""
        self._last = None
        self.surface.release()

    def state(self) -> dict[str, Any]:
        """What a resumed run needs to go on bit for bit: the scheme ``"auto"`` chose, the
        deposition rates the next implicit step starts from, and the passes counted."""
        kept: dict[str, Any] = {"passes": self.passes, "chosen": self.chosen or ""}
        if self._deposition is not None:
            kept["deposition"] = self._deposition
        return kept

    def restore(self, state: dict[str, Any]) -> None:
        self.passes = int(state.get("passes", 0))
        self.chosen = str(state.get("chosen", "")) or None
        deposition = state.get("deposition")
        self._deposition = None if deposition is None else np.array(deposition, dtype=np.float64)

    def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
        if dt > 0.0 and self.forward == "auto" and self.chosen is None:
            try:
                self._choose(elevation, dt)
            except FloatingPointError:
                return float("nan")
        if self._implicit(dt):
            # any step is stable; one whose coefficients overflow has none (NaN)
            try:
                self._step(elevation, dt)
            except FloatingPointError:
                return float("nan")
            return float("inf")
        routing, change = self._step(elevation, dt)
        return fluvial.max_stable_dt(elevation, self.surface.terrain.grid, self.params, routing,
                                     discharge=change.discharge, validated=True)

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        change = self._step(elevation, dt)[1]
        return _change(change.dh, change.budget)

    def last_fluxes(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Discharge Q and sediment flux Q_s (m³/y, float64[ny, nx]) of the latest (sub-)step,
        computed on the elevation at its start (000 Algorithm 1); None before any step."""
        if self._last is None:
            return None
        change = self._last[2]
        return change.discharge, change.sediment_flux


def _joined(first: fluvial.FluvialChange, second: fluvial.FluvialChange,
            dt: float) -> fluvial.FluvialChange:
    """Two consecutive changes of ``dt`` years each as one: Δh and volumes add up, the fluxes
    are their means."""
    a, b = first.budget, second.budget
    budget = MassBudget(a.eroded + b.eroded, a.deposited + b.deposited, a.outflux + b.outflux,
                        a.inflow + b.inflow)
    return fluvial.FluvialChange(first.dh + second.dh, 0.5 * (first.sediment_flux + second.sediment_flux),
                                 0.5 * (first.discharge + second.discharge), budget)


@dataclass
class ThermalProcess:
    """Thermal erosion with rock deposition and its reversal (000 §4)."""

    surface: Surface
    params: thermal.ThermalParams
    scheme: str = "limiter"
    constraints: tuple[str, ...] = thermal.CONSTRAINTS
    name: str = "thermal"

    def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
        return thermal.max_stable_dt(elevation, self.surface.terrain.grid, self.params,
                                     self.surface.outlets(elevation), dt, self.scheme)

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        routing = self.surface.routing(elevation)
        change = thermal.step(elevation, self.surface.terrain.grid, routing.outlets, self.params,
                              dt, routing=routing, scheme=self.scheme,
                              constraints=self.constraints)
        return _change(change.dh, change.budget)


@dataclass
class OutletStepProcess:
    """A process whose step needs only the base-level cells: the thermal cellular automaton
    (Musgrave et al. 1989) and hillslope diffusion (001 §6.4), both forward only.

    ``step(elevation, grid, fixed, params, dt)`` returns a SurfaceChange; ``max_dt(grid,
    params)`` its stable |dt| (None: unconditionally stable).
    """

    surface: Surface
    params: Any
    name: str
    step: Callable[..., Any]
    max_dt: Callable[[Any, Any], float] | None = None

    def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
        if self.max_dt is None:
            return float("inf")
        return self.max_dt(self.surface.terrain.grid, self.params)

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        change = self.step(elevation, self.surface.terrain.grid, self.surface.outlets(elevation),
                           self.params, dt)
        return _change(change.dh, change.budget)


@dataclass
class DebrisProcess:
    """Debris flow along steepest descent, implicit (001 Eq. 8; forward only)."""

    surface: Surface
    params: debris.DebrisParams
    name: str = "debris"

    def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
        return float("inf")

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        routing = self.surface.routing(elevation)
        change = debris.step(elevation, self.surface.terrain.grid, routing.outlets, self.params,
                             dt, routing=routing)
        return _change(change.dh, change.budget)


@dataclass(frozen=True)
class Registered:
    """A process the command line offers: its parameters, how to build it from the surface,
    the parameter values and the run options, and whether it can run backward in time (and,
    if not, why)."""

    parameters: tuple[ParamSpec, ...]
    build: Callable[[Terrain, Boundaries, dict[str, Any], dict[str, Any]], Process]
    summary: str
    backward_refusal: str | None = None


def _values(specs: tuple[ParamSpec, ...], values: dict[str, Any]) -> dict[str, Any]:
    return {spec.name: values[spec.name] for spec in specs}


def _surface(terrain: Terrain, boundaries: Boundaries, method: str = "mfd") -> Surface:
    return Surface(terrain, boundaries, method)


REGISTRY: dict[str, Registered] = {
    "fluvial": Registered(
        fluvial.PARAMETERS,
        lambda t, b, v, o: FluvialProcess(
            _surface(t, b, o.get("method", "mfd")),
            fluvial.FluvialParams(**_values(fluvial.PARAMETERS, v)), o.get("scheme", "limiter"),
            o.get("inflow"), o.get("forward", "explicit")),
        "fluvial erosion with sediment deposition (000 §3)",
    ),
    "thermal": Registered(
        thermal.PARAMETERS,
        lambda t, b, v, o: ThermalProcess(
            _surface(t, b, o.get("method", "mfd")),
            thermal.ThermalParams(**_values(thermal.PARAMETERS, v)), o.get("scheme", "limiter"),
            tuple(o.get("constraints", thermal.CONSTRAINTS))),
        "thermal erosion with rock deposition following the flow (000 §4)",
    ),
    "thermal-ca": Registered(
        thermal_ca.PARAMETERS,
        lambda t, b, v, o: OutletStepProcess(
            _surface(t, b), thermal_ca.ThermalCAParams(**_values(thermal_ca.PARAMETERS, v)),
            "thermal-ca", thermal_ca.step, thermal_ca.max_stable_dt),
        "the classic thermal cellular automaton (Musgrave et al. 1989)",
        thermal_ca.BACKWARD_REFUSAL,
    ),
    "hillslope": Registered(
        hillslope.PARAMETERS,
        lambda t, b, v, o: OutletStepProcess(
            _surface(t, b), hillslope.HillslopeParams(**_values(hillslope.PARAMETERS, v)),
            "hillslope", hillslope.step),
        "linear hillslope diffusion, implicit ADI (001 §6.4)",
        hillslope.BACKWARD_REFUSAL,
    ),
    "debris": Registered(
        debris.PARAMETERS,
        lambda t, b, v, o: DebrisProcess(
            _surface(t, b, "d8"), debris.DebrisParams(**_values(debris.PARAMETERS, v))),
        "debris flow above a critical slope, stronger with drainage area (001 Eq. 8)",
        debris.BACKWARD_REFUSAL,
    ),
}


def build_processes(names: list[str], terrain: Terrain, boundaries: Boundaries,
                    values: dict[str, Any], options: dict[str, Any]) -> list[Process]:
    """The processes ``names`` with their parameters taken from ``values`` (name → number or
    raster). The uplift is given only to the first process that takes it, so that a combined
    run applies it once per step."""
    built, uplift_taken = [], False
    for name in names:
        registered = REGISTRY[name]
        own = _values(registered.parameters, values)
        if UPLIFT.name in own:
            if uplift_taken:
                own[UPLIFT.name] = 0.0
            uplift_taken = True
        built.append(registered.build(terrain, boundaries, own, options))
    return built


#: The glacier model's name in process lists: not a process of the runner (``glaciate`` runs it).
GLACIAL = "glacial"


def parse_process_list(text: str, backward: bool) -> list[str]:
    """``"fluvial,thermal"`` → names, checked against the registry (and the direction)."""
    names = [n.strip().lower() for n in text.split(",") if n.strip()]
    if not names:
        raise InputError("--process needs at least one process name.")
    for name in names:
        if name == GLACIAL and backward:
            raise InputError("glaciers cannot run backward in time (ice flow, transport and glacial "
                             "erosion are not reversible); run them forward with glaciate.")
        if name not in REGISTRY:
            hint = " (glaciers run in glaciate)" if name == GLACIAL else ""
            raise InputError(f"unknown process '{name}'{hint}; choose from {', '.join(REGISTRY)}.")
        refusal = REGISTRY[name].backward_refusal
        if backward and refusal:
            raise InputError(refusal)
    if len(set(names)) != len(names):
        raise InputError(f"--process names a process twice: {text}.")
    return names


def given_values(params_file: Path | None, parameter_values: dict[str, str | None],
                 names: list[str]) -> dict[str, str | None]:
    """Parameter values from --params FILE, overridden by those of the command line."""
    values: dict[str, str | None] = {}
    if params_file is not None:
        declared = {name: REGISTRY[name].parameters for name in names}
        values.update(read_parameter_file(params_file, declared))
    values.update({k: v for k, v in parameter_values.items() if v is not None})
    return values


def inflow_history_for(path: Path | None, names: list[str], terrain: Terrain,
                       boundaries: Boundaries) -> InflowHistory | None:
    """``--inflow FILE`` read on the terrain's grid (None without it), refused when the run has
    no fluvial process or a river enters on an outlet of the start elevation."""
    if path is None:
        return None
    if "fluvial" not in names:
        raise InputError("--inflow brings water and sediment to the fluvial process; add fluvial to "
                         "--process.")
    return read_inflow(path, terrain, boundaries.outlets(terrain.elevation, terrain))


def inflow_for(path: Path | None, names: list[str], terrain: Terrain,
               boundaries: Boundaries) -> fluvial.Inflow | None:
    """A constant ``--inflow FILE`` (runs without ages: erode, unerode), as for
    :func:`inflow_history_for`; an inflow table through time is refused."""
    history = inflow_history_for(path, names, terrain, boundaries)
    if history is None:
        return None
    if not history.constant:
        raise InputError(f"the inflow file {path} changes through time ({history.ages_ka.size} ages); "
                         "an inflow through time needs climate-run, erode and unerode take one "
                         "row per river.")
    return history.at()


def thermal_constraints(text: str) -> tuple[str, ...]:
    """``--thermal-constraints`` → names (``none`` for no constraint)."""
    names = tuple(n.strip().lower() for n in text.split(",") if n.strip())
    if names == ("none",):
        return ()
    unknown = [n for n in names if n not in thermal.CONSTRAINTS]
    if unknown:
        raise InputError(f"unknown thermal constraint '{unknown[0]}'; choose among "
                         f"{', '.join(thermal.CONSTRAINTS)}, or none.")
    return names
