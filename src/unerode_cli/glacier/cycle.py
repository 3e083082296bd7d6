"""Glacial cycles: the glacier model coupled with the processes of ice-free ground (001 §6).

001 §6: "Ice shields the terrain from non-glacial erosion processes, so we do not apply them
when the ice thickness is above a threshold (3 m in our experiments). […] erosion is applied in
the following order: glacial erosion, then, where ice is sufficiently thin, hill slope, followed
by combined fluvial and debris flow erosion." One step of length dt (y), after the glacier step
of ``coupled.step`` (mass balance, ice flow, transport, glacial erosion), by operator splitting:

1. hill-slope diffusion ∂z/∂t = k_h·∇²z (001 §6.4, ADI: ``processes.hillslope``) on the cells
   whose ice is thinner than the shield; the cells under thicker ice are held fixed (Dirichlet),
   so what diffuses into them leaves (the glacier carries it away);
2. debris flow (001 Eq. 8: ``processes.debris``) and fluvial erosion ∂z/∂t = −k_f·A^m·|∇z|^n
   (001 §6.3). The latter is ``processes.fluvial`` with K_d = 0 (no deposition) and a
   precipitation of 1 m/y, so that its discharge Q = p·A (m³/y) is the drainage area A (m²) in
   number and its K is 001's k_f. Both follow the routing of the ice surface b + H towards the
   base level (the map's outlets and, with a sea level, the sea) and the shielded cells: a
   glacier is the base level of the slopes and streams that reach it (they feed its surface);
   the routing fills depressions (priority flood), so rivers cross lakes. 001 §6 updates the
   drainage every 20 steps; so does this loop (``drainage_every``), holding the shielded cells
   of the last update fixed in between;
3. tectonic uplift U·dt (m) on every cell of the domain but the base level, under the ice too.

Sea level (optional, e.g. climate-run's along a chronology, 000 §5): a function of the time
(y since the start of the run → m, the DEM's vertical datum being present sea level). The cells
of the domain whose bed is at or below it join the base level, like the map's edges: hill
slopes and rivers end there and they are not uplifted. They are found again at each update of
the drainage (every ``drainage_every`` steps, the first step included), at the time the step
ends. Without a sea level the base level is the map's outlets alone.

The processes' own uplift is left at 0; each process returns a change (``SurfaceChange``), applied
here in turn. Units: metres, years. Nothing here reads or writes files.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from unerode_cli.glacier.coupled import GlacierState, Stopwatch
from unerode_cli.grid import Grid
from unerode_cli.processes import debris, fluvial, hillslope
from unerode_cli.processes.budget import SurfaceChange
from unerode_cli.processes.debris import DebrisParams
from unerode_cli.processes.fluvial import FluvialParams
from unerode_cli.processes.hillslope import HillslopeParams
from unerode_cli.processes.parameters import UPLIFT, ParamSpec

#: Ice thickness (m) above which the bed is shielded from the other processes (001 §6: 3 m).
SHIELD_THICKNESS = 3.0
#: Steps between two updates of the drainage (001 §6: 20).
DRAINAGE_EVERY = 20
#: 001 Table 1's fluvial law (k_f in m^(1−2m)·y^(−1) for A in m²: Table 1 prints m^(2m−1), whose
#: sign of the exponent cannot give a rate in m/y), m and n.
FLUVIAL_K_F, FLUVIAL_M, FLUVIAL_N = 5e-6, 0.4, 1.0

#: 001 §6.3's fluvial erodibility as a parameter (``--k-f``).
K_F = ParamSpec("k_f", "m^(1-2m)/y", FLUVIAL_K_F, "fluvial erodibility k_f for a drainage area A in m² "
                "(001 §6.3, Table 1: 1.5e-6 – 5e-6)", minimum=0.0, raster=True)
HILLSLOPE_PARAMETERS = tuple(spec for spec in hillslope.PARAMETERS if spec.name != "uplift")
#: 001 Table 1's k_da = 10 read with the drainage area A in km², i.e. 10·(1e-6)^q m^(−2q) for A in
#: m² at its q = 0.8. With A in m² (``processes.debris``'s own default), Table 1's values erode every
#: slope steeper than s_c = 37° at metres per year on real terrain (K' = k_df·(1 + k_da·A^q) ≈ 0.5
#: m/y at A = one 46 m cell; a 32² crop of Grindelwald lost 140 m in 30 y), where rock walls retreat
#: at 0.1–2 mm/y (Moore et al. 2009); in km², K' is 1.3e-4 m/y at 1 ha and 1.1e-3 m/y at 1 km².
#: The cost: on 100 m cells debris flow is then 1e4–2e4 times slower and no longer lowers the
#: cliffs that glaciers carve in synthetic terrain on glacial time scales (001 Fig. 14's "quickly
#: reduced"; ``tests/glacier/test_fig14_coupling.py``: 39° with Table 1 as printed, 45–48° with
#: this default, 47° glacial-only). Runs after the paper's synthetic terrains pass ``--k-da 10``.
DEBRIS_K_DA = 10.0 * 1e-6 ** 0.8
DEBRIS_PARAMETERS = tuple(
    replace(spec, default=DEBRIS_K_DA,
            help="weight k_da of the drainage area A (m²) in the debris-flow erosion (001 Eq. 8): "
                 "Table 1's 10 with A in km², i.e. 10·(1e-6)^0.8") if spec.name == "k_da" else spec
    for spec in debris.PARAMETERS)
FLUVIAL_PARAMETERS = (K_F, *(spec for spec in fluvial.PARAMETERS if spec.name in ("m", "n")))
#: The parameters of the ice-free processes and the uplift, as the CLI offers them (``--k-h``, …).
PARAMETERS = (UPLIFT, *HILLSLOPE_PARAMETERS, *DEBRIS_PARAMETERS, *FLUVIAL_PARAMETERS)


def surface_params(values: dict[str, float | np.ndarray], hillslope_on: bool = True, debris_on: bool = True,
                   fluvial_on: bool = True, shield: float = SHIELD_THICKNESS,
                   drainage_every: int = DRAINAGE_EVERY) -> SurfaceParams:
    """``SurfaceParams`` from values of ``PARAMETERS`` by name (the defaults where absent)."""
    def value(spec: ParamSpec) -> float | np.ndarray:
        return values.get(spec.name, spec.default)

    return SurfaceParams(
        shield=shield,
        hillslope=HillslopeParams(**{s.name: value(s) for s in HILLSLOPE_PARAMETERS})
        if hillslope_on else None,
        debris=DebrisParams(**{s.name: value(s) for s in DEBRIS_PARAMETERS}) if debris_on else None,
        fluvial=fluvial_of_table_1(**{s.name: value(s) for s in FLUVIAL_PARAMETERS}) if fluvial_on else None,
        uplift=value(UPLIFT), drainage_every=drainage_every)


def fluvial_of_table_1(k_f: float | np.ndarray = FLUVIAL_K_F, m: float = FLUVIAL_M,
                       n: float = FLUVIAL_N) -> FluvialParams:
    """001 §6.3's stream power law as ``processes.fluvial`` parameters: K = k_f, K_d = 0, p = 1 m/y."""
    return FluvialParams(uplift=0.0, k=k_f, k_d=0.0, precipitation=1.0, m=m, n=n)


@dataclass(frozen=True)
class SurfaceParams:
    """The processes of ice-free ground (module docstring); None switches a process off.

    ``shield`` (m): ice thickness that shields the bed; ``uplift`` (m/y, number or raster);
    ``drainage_every``: steps between updates of the routing.
    """

    shield: float = SHIELD_THICKNESS
    hillslope: HillslopeParams | None = field(default_factory=HillslopeParams)
    debris: DebrisParams | None = field(default_factory=lambda: DebrisParams(k_da=DEBRIS_K_DA))
    fluvial: FluvialParams | None = field(default_factory=fluvial_of_table_1)
    uplift: float | np.ndarray = 0.0
    drainage_every: int = DRAINAGE_EVERY

    def validate(self, grid: Grid) -> None:
        """Raise ValueError (one sentence) for a value out of range."""
        if not (self.shield >= 0.0 and np.isfinite(self.shield)):
            raise ValueError(f"the shield thickness must be finite and ≥ 0 m, got {self.shield:g} m")
        if self.drainage_every < 1:
            raise ValueError(f"the drainage must be updated every ≥ 1 steps, got {self.drainage_every}")
        uplift = np.asarray(self.uplift, dtype=np.float64)
        if uplift.ndim and uplift.shape != grid.shape:
            raise ValueError(f"the uplift map {uplift.shape} must have the grid's shape {grid.shape}")
        if not np.isfinite(uplift[grid.valid] if uplift.ndim else uplift).all():
            raise ValueError("the uplift must be finite inside the domain")
        for params in (self.hillslope, self.debris, self.fluvial):
            if params is not None:
                params.validate(grid)


class IceFreeErosion:
    """Steps the processes of ice-free ground after each glacier step (module docstring); keeps
    the routing between its updates and the volumes (m³) each process moved so far: ``removed``,
    its outflux (carried out of the domain; hill slopes may bring material in from a fixed cell
    higher than its neighbours, a negative outflux); ``lowered`` Σ max(0, −Δz)·dx·dy and
    ``raised`` Σ max(0, Δz)·dx·dy over the domain, summed step by step (the rock it took from
    the bed and the material it laid on it: lowered − raised = −Σ Δz·dx·dy of that process), and
    ``uplifted`` Σ U·dt·dx·dy (m³). ``outlets``: bool[ny, nx] base-level cells of the map;
    ``sea_level``: None, or the sea level (m) at a time (y since the start of the run), whose
    cells join the base level (module docstring). ``base_level``: bool[ny, nx], the outlets and
    the sea's cells of the last update. ``seconds``: wall-clock time spent so far on each process,
    on the updates of the drainage (routing) and on the uplift."""

    def __init__(self, params: SurfaceParams, grid: Grid, outlets: np.ndarray,
                 sea_level: Callable[[float], float] | None = None) -> None:
        params.validate(grid)
        self.params, self.grid = params, grid
        self.outlets = np.asarray(outlets, dtype=bool) & grid.valid
        self.sea_level = sea_level
        self.base_level = self.outlets
        self.steps = 0
        self.seconds = dict.fromkeys(("hillslope", "drainage", "debris", "fluvial", "uplift"), 0.0)
        self._routing = None
        self._fixed: np.ndarray | None = None
        self._routed: np.ndarray | None = None  # the surface (m) the routing was computed on
        self.removed = {"hillslope": 0.0, "debris": 0.0, "fluvial": 0.0}
        self.lowered = dict.fromkeys(self.removed, 0.0)
        self.raised = dict.fromkeys(self.removed, 0.0)
        self.uplifted = 0.0

    def saved(self) -> dict[str, np.ndarray | int | dict[str, float]]:
        """What ``restore`` needs to go on as if never stopped: the step count, the base level,
        the fixed cells and routed surface of the last drainage update, the totals."""
        empty = np.zeros((0, 0))
        return {"steps": self.steps, "base_level": self.base_level,
                "fixed": empty if self._fixed is None else self._fixed,
                "routed": empty if self._routed is None else self._routed,
                "removed": dict(self.removed), "lowered": dict(self.lowered), "raised": dict(self.raised),
                "uplifted": self.uplifted, "seconds": dict(self.seconds)}

    def restore(self, saved: dict) -> None:
        """Continue from ``saved()``: the routing is computed again on the saved surface."""
        from unerode_cli.hydro.routing import route

        self.steps = int(saved["steps"])
        self.base_level = np.asarray(saved["base_level"], dtype=bool)
        self.removed.update(saved["removed"])
        self.lowered.update(saved.get("lowered", {}))
        self.raised.update(saved.get("raised", {}))
        self.uplifted = float(saved.get("uplifted", 0.0))
        self.seconds.update(saved["seconds"])
        fixed, routed = np.asarray(saved["fixed"]), np.asarray(saved["routed"])
        if fixed.size and routed.size:
            self._fixed, self._routed = fixed.astype(bool), routed.astype(np.float64)
            self._routing = route(self._routed, self.grid, self._fixed, "d8")

    def shielded(self, thickness: np.ndarray) -> np.ndarray:
        """bool[ny, nx]: cells of the domain under ice thicker than the shield."""
        return self.grid.valid & (np.asarray(thickness) > self.params.shield)

    def sea(self, state: GlacierState) -> np.ndarray:
        """bool[ny, nx]: cells of the domain whose bed is at or below the sea level (m) at
        ``state.time`` (y); none without a sea level."""
        if self.sea_level is None:
            return np.zeros(self.grid.shape, dtype=bool)
        with np.errstate(invalid="ignore"):
            return self.grid.valid & (state.bed <= self.sea_level(state.time))

    def __call__(self, state: GlacierState, dt: float) -> GlacierState:
        """The state after one step dt (y) of the ice-free processes and uplift."""
        from unerode_cli.hydro.routing import route

        p, grid = self.params, self.grid
        clock = Stopwatch(self.seconds)
        update = self.steps % p.drainage_every == 0
        if update:
            self.base_level = self.outlets | self.sea(state)
        bed = state.bed
        if p.hillslope is not None:
            change = hillslope.step(bed, grid, self.base_level | self.shielded(state.thickness), p.hillslope,
                                    dt)
            bed = self._apply(bed, change, "hillslope")
            clock.lap("hillslope")
        if p.debris is not None or p.fluvial is not None:
            if update:
                self._fixed = self.base_level | self.shielded(state.thickness)
                self._routed = bed + state.thickness
                self._routing = route(self._routed, grid, self._fixed, "d8")
                clock.lap("drainage")
            if p.debris is not None:
                change = debris.step(bed, grid, self._fixed, p.debris, dt, routing=self._routing)
                bed = self._apply(bed, change, "debris")
                clock.lap("debris")
            if p.fluvial is not None:
                change = fluvial.step(bed, grid, self._fixed, p.fluvial, dt, routing=self._routing,
                                      validated=True)
                bed = self._apply(bed, change, "fluvial")
                clock.lap("fluvial")
        uplift = np.where(grid.valid & ~self.base_level, np.asarray(p.uplift, dtype=np.float64) * dt, 0.0)
        self.uplifted += float(uplift.sum()) * grid.cell_area
        self.steps += 1
        clock.lap("uplift")
        return replace(state, bed=bed + uplift)

    def _apply(self, bed: np.ndarray, change: SurfaceChange, name: str) -> np.ndarray:
        """The bed after ``change`` of process ``name``, its volumes counted."""
        dh = np.where(self.grid.valid, change.dh, 0.0)
        self.removed[name] += change.budget.outflux
        self.lowered[name] += float(np.sum(np.maximum(-dh, 0.0))) * self.grid.cell_area
        self.raised[name] += float(np.sum(np.maximum(dh, 0.0))) * self.grid.cell_area
        return bed + change.dh
