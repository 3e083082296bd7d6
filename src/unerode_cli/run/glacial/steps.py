"""The time steps of a glacier run (``glacier.coupled.run`` with the processes of ice-free
ground, ``glacier.cycle``): progress, divergence guards, ice snapshots, timeline rows,
checkpoints and resume.

Checkpoints: every ``--checkpoint-every`` steps the run's whole state (bed, ice, the last
velocities, the step cap, the totals, the timeline so far and the state of the ice-free
processes: ``_saved``) goes to ``.OUT.checkpoint.npz`` beside OUT (``io.checkpoints``); ``--resume``
continues from it with the steps an uninterrupted run would take. ``--max-steps``, or a
cancelled progress, ends an invocation after a step: the loop returns normally with the run so
far, checkpointed. A finished run's outputs remove its checkpoint (``outputs.write_glacier``); a
run that diverges removes it with everything else it wrote.

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
from unerode_cli.io.checkpoints import checkpoint_path, read_state_checkpoint, write_state_checkpoint
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.divergence import DivergenceGuard, max_rate
from unerode_cli.run.glacial.outputs import save_layer, timeline_row
from unerode_cli.run.glacial.plan import PreparedGlacierRun, snapshot_base
from unerode_cli.run.job import Progress
from unerode_cli.run.outputs import snapshot_path

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
    progress.start(float(prepared.times[-1]), prepared.command, unit="years")
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
    """The loop of ``coupled.run``, from the beginning or the checkpoint; ``check`` after each step
    guards, reports, writes snapshots, timeline rows and checkpoints, and ends the loop (returns
    True) at ``--max-steps`` or when the progress is cancelled."""
    run, terrain = prepared.run, prepared.terrain
    grid = terrain.grid
    resumed = _resume(prepared, ice_free, progress)
    timeline: list[dict[str, Any]] = [] if resumed is None else resumed.timeline
    snapshots: list[Path] = [] if resumed is None else resumed.snapshots
    earlier = 0.0 if resumed is None else resumed.wall
    if resumed is None:
        result = coupled.RunResult(state, [state.time], [coupled.ice_volume(state.thickness, grid)])
    else:
        result, state = resumed.result, resumed.result.state
    stop_at = None if run.max_steps is None else result.steps + run.max_steps
    end_time = float(prepared.times[-1])
    bed_guard = DivergenceGuard(terrain.elevation, hint=DIVERGENCE_HINT)
    surface_guard = DivergenceGuard(terrain.elevation + prepared.thickness,
                                    uplift_rate=max_rate(prepared.params.p_max), hint=DIVERGENCE_HINT)
    thick_note = _ThickIceNote(prepared.params, progress)
    stopped = False

    def check(new: coupled.GlacierState, report: coupled.StepReport, k: int) -> bool:
        nonlocal stopped
        where = f"in step {k} (t = {new.time:g} y)"
        bed_guard.check(new.bed, new.time, where)
        surface_guard.check(new.bed + new.thickness, new.time, where)
        thick_note.check(new)
        if run.timeline is not None:
            timeline.append(timeline_row(prepared, new, report, ice_free,
                                         outlets if ice_free is None else ice_free.base_level))
        progress.advance(_step_info(report), done=new.time)
        if any(math.isclose(new.time, t, rel_tol=1e-12) for t in prepared.snapshot_times):
            path = snapshot_path(snapshot_base(run), len(snapshots) + 1)
            save_layer(prepared, new.thickness, path, "m", {"time_years": new.time}, new.time)
            snapshots.append(path)
        stopped = (k == stop_at or progress.cancelled()) and new.time < end_time
        if k % run.checkpoint_every == 0 or stopped:
            saved = _saved(_Resumed(result, timeline, snapshots, earlier + time.perf_counter() - start),
                           ice_free)
            write_state_checkpoint(checkpoint_path(run.output), prepared.fingerprint, k, saved)
        return stopped

    times = prepared.times[prepared.times > state.time + 1e-9 * max(run.dt, 1.0)]
    try:
        coupled.run(state, grid, prepared.params, prepared.ela, times, None, check, ice_free, result)
    except coupled.UnstableStep as exc:
        raise InputError(
            f"--dt {exc.dt:g} y is above the stable explicit ice-transport step {exc.stable:.3g} y "
            f"(reached at t = {exc.time:g} y); lower --dt or drop --no-substep.") from None
    except coupled.Diverged as exc:
        raise RunFailure(f"{exc}; lower --dt or --transport-cfl, or use --transport explicit") from None
    except coupled.TooManySubsteps as exc:
        raise RunFailure(f"{exc}; use the multi-scale transport (the default) or a shorter --dt") from None
    return GlacierOutcome(result, timeline, snapshots, ice_free, note, earlier, stopped)


@dataclass
class _Resumed:
    """A run so far: its result (state, volume series, totals), the timeline rows and snapshots
    written and the wall-clock seconds spent."""

    result: coupled.RunResult
    timeline: list[dict[str, Any]]
    snapshots: list[Path]
    wall: float


#: The totals of a ``coupled.RunResult`` a checkpoint keeps (besides ``seconds``).
_RESULT_TOTALS = ("steps", "substeps", "resolves", "evaluations", "unconverged", "max_residual", "eroded",
                  "retries", "cap")
#: The arrays of ``IceFreeErosion.saved()``, kept as ``free_NAME``.
_ICE_FREE_ARRAYS = ("base_level", "fixed", "routed")


def _saved(run: _Resumed, ice_free: cycle.IceFreeErosion | None) -> dict[str, Any]:
    """The state a checkpoint keeps (arrays, and numbers, text, lists and mappings of them):
    bed, ice and last velocities, the volume series and totals (the step cap included), the
    timeline, the snapshots, the wall time and the ice-free processes' ``saved()`` state."""
    result = run.result
    state = result.state
    lattice = state.lattice if state.lattice is not None else (np.zeros(0), np.zeros(0))
    saved: dict[str, Any] = {
        "bed": state.bed, "thickness": state.thickness, "time": state.time, "lattice_u": lattice[0],
        "lattice_v": lattice[1], "series_times": list(result.times), "series_volumes": list(result.volumes),
        "totals": {name: getattr(result, name) for name in _RESULT_TOTALS}, "seconds": dict(result.seconds),
        "timeline": run.timeline, "snapshots": [str(p) for p in run.snapshots], "wall": run.wall,
        "ice_free": None}
    if ice_free is not None:
        free = ice_free.saved()
        saved["ice_free"] = {name: value for name, value in free.items() if name not in _ICE_FREE_ARRAYS}
        saved.update({f"free_{name}": np.asarray(free[name]) for name in _ICE_FREE_ARRAYS})
    return saved


def _resume(prepared: PreparedGlacierRun, ice_free: cycle.IceFreeErosion | None,
            progress: Progress) -> _Resumed | None:
    """The run to continue with --resume (None: start from the beginning); the ice-free
    processes are restored to their state at the checkpoint."""
    run = prepared.run
    assert run.output is not None
    path = checkpoint_path(run.output)
    if not run.resume:
        return None
    if not path.exists():
        progress.note(f"note: no checkpoint {path.name} to resume from; starting from the beginning.")
        return None
    fingerprint, done, saved = read_state_checkpoint(path)
    if fingerprint != prepared.fingerprint:
        raise InputError(f"the checkpoint {path} belongs to a run with other inputs or options; run "
                         "without --resume (or with the same options).")
    free = saved["ice_free"]
    if (free is None) != (ice_free is None):
        raise InputError(f"the checkpoint {path} does not match this run's processes of ice-free ground.")
    if ice_free is not None:
        ice_free.restore({**free, **{name: saved[f"free_{name}"] for name in _ICE_FREE_ARRAYS}})
    lattice = (saved["lattice_u"], saved["lattice_v"]) if saved["lattice_u"].size else None
    state = coupled.GlacierState(saved["bed"], saved["thickness"], float(saved["time"]), lattice)
    result = coupled.RunResult(state, list(map(float, saved["series_times"])),
                               list(map(float, saved["series_volumes"])),
                               seconds={**dict.fromkeys(coupled.WALL_TIME_PARTS, 0.0), **saved["seconds"]},
                               **saved["totals"])
    progress.note(f"note: resuming after step {done} (t = {state.time:g} y of {prepared.times[-1]:g}).")
    return _Resumed(result, list(saved["timeline"]), [Path(p) for p in saved["snapshots"]],
                    float(saved["wall"]))


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
    return text


def _no_ice_note(terrain: Terrain, ela: coupled.Ela, ice_free: bool) -> str:
    peak = float(np.nanmax(terrain.elevation))
    lowest = float(np.min(ela.values if isinstance(ela, coupled.ElaTable) else np.asarray(ela)))
    outcome = "only the processes of ice-free ground change the bed" if ice_free else "the bed is unchanged"
    return (f"note: the ELA (lowest {lowest:g} m) is above every peak of the DEM (highest {peak:g} m): "
            f"no ice forms and {outcome}.")
