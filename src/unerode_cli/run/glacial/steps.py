"""The time steps of a glacier run (``glacier.coupled.Stepping`` with the processes of ice-free
ground, ``glacier.cycle``) through the shared stepping loop (``run.stepping.step_through``):
progress, divergence guards, ice snapshots, timeline rows, checkpoints and resume.

The number of steps is not known in advance (the cold-start ramp and the rejected steps of
``coupled.Stepping``): the loop runs until the step that reaches the last time, and its progress
counts simulated years. Checkpoints: every ``--checkpoint-every`` steps the run's whole state
(``GlacierSteps.state``: bed, ice, the last velocities, the step cap, the totals, the timeline
so far, the state of the ice-free processes and, with ``--iceflow cnn``, the network's weights
and optimiser) goes to ``.OUT.checkpoint.npz`` beside OUT
(``io.checkpoints.write_state_checkpoint``); ``--resume`` continues from it with the steps an
uninterrupted run would take. ``--max-steps``, or a cancelled progress, ends an invocation after
a step: the loop returns normally with the run so far, checkpointed. A finished run's outputs
remove its checkpoint (``outputs.write_glacier``); a run that diverges removes it with
everything else it wrote.

Divergence (``DivergenceGuard``, as erode and climate-run): after every step the bed, and the
ice surface b + H, must be finite and within 5 × the DEM's relief (+ 100 m) of the starting DEM
— the surface also may rise by p_max (m/y) times the years run, as snow piles up. A run that
leaves that bound stops at that step (RunFailure, exit 1).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.errors import InputError, RunFailure
from unerode_cli.glacier import coupled, cycle, lakes
from unerode_cli.hydro.outlets import outlet_mask
from unerode_cli.io.checkpoints import checkpoint_path
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.divergence import DivergenceGuard, max_rate
from unerode_cli.run.glacial.outputs import save_layer, timeline_row
from unerode_cli.run.glacial.plan import PreparedGlacierRun, snapshot_base
from unerode_cli.run.job import Progress
from unerode_cli.run.outputs import snapshot_path
from unerode_cli.run.stepping import Checkpoints, StepInfo, step_through

#: Ice thicker than this (m) under the multi-scale transport at a CFL number above
#: ``THICK_ICE_CFL`` gets a note: one-cell grooves in the surface of ice this thick grew into a
#: divergence at 001's c = 0.1 (001 Fig. 6's ice sheet of up to 1.3 km at 250 m cells; the
#: Grindelwald cycle under 2–2.5 km at 92 m), and 0.05 kept both down (``coupled._multiscale_cfl``).
THICK_ICE_M = 1000.0
THICK_ICE_CFL = 0.05
DIVERGENCE_HINT = ("lower --dt or, under thick ice, --transport-cfl (0.05 kept 001 Fig. 6's ice sheet "
                   "stable), or raise --sliding-C if the ice slides at km/y")


@dataclass
class GlacierOutcome:
    """A run's end: its result (state, volume series, totals), the timeline rows and snapshots
    written, the ice-free processes (None without them), the note of a run without ice, the
    wall-clock seconds, whether it stopped before its end (``--max-steps``, cancelled), and for a
    finished run the velocities of its final geometry (when ``--velocity``/``--sliding`` ask)
    and its lake depth (m, when ``--lakes`` asks)."""

    result: coupled.RunResult
    timeline: list[dict[str, Any]]
    snapshots: list[Path]
    ice_free: cycle.IceFreeErosion | None
    note: str
    wall: float
    stopped: bool = False
    final_flow: coupled.FlowField | None = None
    lake_depth: np.ndarray | None = None


def run_glacier(prepared: PreparedGlacierRun, progress: Progress) -> GlacierOutcome:
    """Run (or resume) the coupled model over ``prepared.times``; the progress counts simulated
    years, its ``advance`` info is a line on the step (ice volume, fastest ice, the velocity
    solver's iterations and relative residual)."""
    run, terrain = prepared.run, prepared.terrain
    grid = terrain.grid
    start = time.perf_counter()
    state = coupled.GlacierState(coupled.fill_outside(terrain.elevation, grid.valid), prepared.thickness)
    outlets = outlet_mask(grid)  # the map's edges and the borders of nodata
    ice_free = _ice_free_erosion(prepared, outlets)
    note = ""
    never = coupled.never_glaciated(state.bed, state.thickness, grid, prepared.ela)
    if never:
        note = _no_ice_note(terrain, prepared.ela, ice_free is not None)
        progress.note(note)
    if never and ice_free is None:
        outcome = _without_ice(prepared, state, note)
        progress.start(float(prepared.times[-1]), prepared.command, unit="years")
        progress.advance("no ice", done=outcome.result.state.time)
    else:
        outcome = _steps(prepared, state, ice_free, outlets, note, progress, start)
    if not outcome.stopped:
        final = outcome.result.state
        if run.velocity is not None or run.sliding is not None:
            outcome.final_flow = coupled.flow_field(final.bed, final.thickness, grid, prepared.params,
                                                    warm=final.lattice)
        if run.lakes is not None:
            outcome.lake_depth = lakes.lake_depth(final.bed, final.thickness, grid, outlets)
    outcome.wall = time.perf_counter() - start + outcome.wall
    return outcome


def _without_ice(prepared: PreparedGlacierRun, state: coupled.GlacierState, note: str) -> GlacierOutcome:
    """A run in which nothing can change: the bed as it is, empty ice snapshots at their times."""
    end = coupled.GlacierState(state.bed, state.thickness, float(prepared.times[-1]))
    result = coupled.RunResult(end, [0.0, end.time], [0.0, 0.0], steps=0)
    snapshots = []
    for k, t in enumerate(prepared.snapshot_times, start=1):
        path = snapshot_path(snapshot_base(prepared.run), k)
        save_layer(prepared, state.thickness, path, "m", {"time_years": t}, t)
        snapshots.append(path)
    return GlacierOutcome(result, [], snapshots, None, note, 0.0)


def _steps(prepared: PreparedGlacierRun, state: coupled.GlacierState, ice_free: cycle.IceFreeErosion | None,
           outlets: np.ndarray, note: str, progress: Progress, start: float) -> GlacierOutcome:
    """The steps of ``coupled.Stepping`` through the shared stepping loop (``run.stepping``:
    resume, progress in simulated years, --max-steps, cancel, checkpoints), from the beginning
    or the checkpoint; ``GlacierSteps.step`` guards, writes snapshots and timeline rows."""
    run = prepared.run
    assert run.output is not None
    steps = GlacierSteps(prepared, state, ice_free, outlets, progress, start)
    checkpoints = Checkpoints(checkpoint_path(run.output), run.checkpoint_every, run.resume,
                              prepared.fingerprint)
    try:
        stepped = step_through(steps, None, progress, prepared.command, checkpoints, run.max_steps,
                               years=float(prepared.times[-1]))
    except coupled.UnstableStep as exc:
        raise InputError(
            f"--dt {exc.dt:g} y is above the stable explicit ice-transport step {exc.stable:.3g} y "
            f"(reached at t = {exc.time:g} y); lower --dt or drop --no-substep.") from None
    except coupled.Diverged as exc:
        raise RunFailure(f"{exc}; lower --dt or --transport-cfl, or use --transport explicit") from None
    except coupled.TooManySubsteps as exc:
        raise RunFailure(f"{exc}; use the multi-scale transport (the default) or a shorter --dt") from None
    return GlacierOutcome(steps.stepping.result, steps.timeline, steps.snapshots, ice_free, note,
                          steps.earlier, not stepped.finished)


class GlacierSteps:
    """A glacier run as the shared stepping loop drives it (``run.stepping.Stepper``): one step
    is one accepted step of ``coupled.Stepping`` (with the ice-free processes after it), checked
    by the divergence guards, with its timeline row and, at a snapshot time, its ice snapshot.
    Its state (``state``/``restore``) is the whole run so far: bed, ice, last velocities, the
    volume series and totals (the step cap included), the timeline, the snapshots, the wall time
    (``earlier``: seconds of the invocations before this one) and the ice-free processes'."""

    def __init__(self, prepared: PreparedGlacierRun, state: coupled.GlacierState,
                 ice_free: cycle.IceFreeErosion | None, outlets: np.ndarray, progress: Progress,
                 start: float) -> None:
        terrain = prepared.terrain
        self.prepared, self.ice_free, self.start = prepared, ice_free, start
        self.base_level = outlets if ice_free is None else ice_free.base_level
        self.stepping = self._stepping(state)
        self.timeline: list[dict[str, Any]] = []
        self.snapshots: list[Path] = []
        self.earlier = 0.0
        self.bed_guard = DivergenceGuard(terrain.elevation, hint=DIVERGENCE_HINT)
        self.surface_guard = DivergenceGuard(terrain.elevation + prepared.thickness,
                                             uplift_rate=max_rate(prepared.params.p_max),
                                             hint=DIVERGENCE_HINT)
        self.thick_note = _ThickIceNote(prepared.params, progress)

    def _stepping(self, state: coupled.GlacierState,
                  result: coupled.RunResult | None = None) -> coupled.Stepping:
        prepared = self.prepared
        return coupled.Stepping(state, prepared.terrain.grid, prepared.params, prepared.ela, prepared.times,
                                self.ice_free, result)

    def step(self, k: int) -> StepInfo:
        prepared, run = self.prepared, self.prepared.run
        if self.stepping.finished:  # resumed from a checkpoint of the last step
            return StepInfo(done=self.stepping.state.time, last=True)
        report = self.stepping.advance()
        new = self.stepping.state
        where = f"in step {k + 1} (t = {new.time:g} y)"
        self.bed_guard.check(new.bed, new.time, where)
        self.surface_guard.check(new.bed + new.thickness, new.time, where)
        self.thick_note.check(new)
        if run.timeline is not None:
            self.timeline.append(timeline_row(prepared, new, report, self.ice_free, self.base_level))
        if any(math.isclose(new.time, t, rel_tol=1e-12) for t in prepared.snapshot_times):
            path = snapshot_path(snapshot_base(run), len(self.snapshots) + 1)
            save_layer(prepared, new.thickness, path, "m", {"time_years": new.time}, new.time)
            self.snapshots.append(path)
        return StepInfo(_step_info(report), done=new.time, last=self.stepping.finished)

    def state(self) -> dict[str, Any]:
        """The state a checkpoint keeps (arrays, and numbers, text, lists and mappings of them):
        the run so far (``coupled.RunResult.saved``), the timeline, the snapshots, the wall time,
        the ice-free processes' (``saved()``: its arrays as ``free_NAME``) and, with ``--iceflow
        cnn``, the network's weights, optimiser state and counters (``CnnIceflow.saved``)."""
        saved: dict[str, Any] = {
            **self.stepping.result.saved(), "timeline": self.timeline,
            "snapshots": [str(p) for p in self.snapshots],
            "wall": self.earlier + time.perf_counter() - self.start, "ice_free": None}
        if self.ice_free is not None:
            free = self.ice_free.saved()
            saved["ice_free"] = {name: value for name, value in free.items() if name not in _ICE_FREE_ARRAYS}
            saved.update({f"free_{name}": np.asarray(free[name]) for name in _ICE_FREE_ARRAYS})
        if self.prepared.params.cnn is not None:
            saved.update(self.prepared.params.cnn.saved())
        return saved

    def restore(self, saved: dict[str, Any]) -> None:
        """Take back a checkpoint's state; the ice-free processes and the CNN's network too.
        InputError when the checkpoint's processes of ice-free ground or network are not this
        run's."""
        free, model = saved["ice_free"], self.prepared.params.cnn
        where = f"the checkpoint {checkpoint_path(self.prepared.run.output)}"
        if (free is None) != (self.ice_free is None):
            raise InputError(f"{where} does not match this run's processes of ice-free ground.")
        if model is not None:
            try:
                model.restore(saved)
            except (KeyError, ValueError) as exc:
                raise InputError(f"{where} does not hold this run's CNN ice-flow network ({exc}).") from None
        if self.ice_free is not None:
            self.ice_free.restore({**free, **{name: saved[f"free_{name}"] for name in _ICE_FREE_ARRAYS}})
        result = coupled.RunResult.restored(saved)
        self.stepping = self._stepping(result.state, result)
        self.timeline = list(saved["timeline"])
        self.snapshots = [Path(p) for p in saved["snapshots"]]
        self.earlier = float(saved["wall"])


#: The arrays of ``IceFreeErosion.saved()``, kept as ``free_NAME``.
_ICE_FREE_ARRAYS = ("base_level", "fixed", "routed")


class _ThickIceNote:
    """Tells the user once when the ice grows thicker than ``THICK_ICE_M`` under a multi-scale CFL
    number above ``THICK_ICE_CFL``."""

    def __init__(self, params: coupled.CoupledParams, progress: Progress) -> None:
        self.progress = progress
        self.cfl = params.multiscale_cfl
        self.pending = params.transport == "multiscale" and params.multiscale_cfl > THICK_ICE_CFL

    def check(self, state: coupled.GlacierState) -> None:
        if not self.pending:
            return
        thickest = float(state.thickness.max())
        if thickest > THICK_ICE_M:
            self.pending = False
            self.progress.note(
                f"note: the ice is {thickest:.0f} m thick at t = {state.time:g} y; under ice this thick "
                f"--transport-cfl {self.cfl:g} can grow one-cell grooves in its surface until the run "
                f"diverges (an ice sheet, a glacial maximum): {THICK_ICE_CFL:g} keeps them down.")


def _ice_free_erosion(prepared: PreparedGlacierRun, outlets: np.ndarray) -> cycle.IceFreeErosion | None:
    """The processes of ice-free ground after each glacier step (``glacier.cycle``) towards
    ``outlets`` and the run's sea; None when every one is off and there is no uplift."""
    surface = prepared.surface
    if surface.hillslope is surface.debris is surface.fluvial is None and not np.any(surface.uplift):
        return None
    return cycle.IceFreeErosion(surface, prepared.terrain.grid, outlets, prepared.sea_level)


def _step_info(report: coupled.StepReport) -> str:
    """One step in words: the ice volume, the fastest column, and the velocity solve."""
    flow = report.flow
    text = f"step {report.dt:g} y, ice {report.volume / 1e9:.4g} km³, max speed {flow.max_speed():.4g} m/y"
    if flow.lattice is not None:
        text += (f", Blatter–Pattyn {flow.iterations} iterations, residual {flow.residual:.3g}"
                 + ("" if flow.converged else " (not converged)"))
    if flow.takeover is not None:
        text += ", CNN taken over by the converged solver" if flow.takeover else ", CNN on its own"
    return text


def _no_ice_note(terrain: Terrain, ela: coupled.Ela, ice_free: bool) -> str:
    peak = float(np.nanmax(terrain.elevation))
    lowest = float(np.min(ela.values if isinstance(ela, coupled.ElaTable) else np.asarray(ela)))
    outcome = "only the processes of ice-free ground change the bed" if ice_free else "the bed is unchanged"
    return (f"note: the ELA (lowest {lowest:g} m) is above every peak of the DEM (highest {peak:g} m): "
            f"no ice forms and {outcome}.")
