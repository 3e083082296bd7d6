"""The `erode` / `unerode` job: plan (check everything, read inputs), run on arrays, write."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.hydro.routing import release_scratch
from unerode_cli.io.checkpoints import check_checkpoint, checkpoint_path
from unerode_cli.io.netcdf_files import check_series, write_series
from unerode_cli.io.netcdf_raster import ELEVATION
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_header, read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.erode.options import BACKWARD_SCHEMES, FORWARD_SCHEMES, OPTIONS
from unerode_cli.jobs.erode.start import take_elevation
from unerode_cli.processes.parameters import UPLIFT
from unerode_cli.run.boundaries import boundaries_from_options
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import declared
from unerode_cli.run.divergence import DivergenceGuard, max_rate
from unerode_cli.run.fingerprint import run_fingerprint
from unerode_cli.run.job import Job, Progress
from unerode_cli.run.memory import check_command
from unerode_cli.run.outputs import (
    TIME_TAG,
    Outputs,
    check_png,
    check_raster,
    field_preview,
    save,
    snapshot_path,
)
from unerode_cli.run.parameter_maps import resolve
from unerode_cli.run.registry import (
    REGISTRY,
    build_processes,
    given_values,
    inflow_for,
    parse_process_list,
    thermal_constraints,
)
from unerode_cli.run.runner import Budget, Process, RunReport, StepApplier
from unerode_cli.run.stepping import (
    NO_CHECKPOINTS,
    Checkpoints,
    StepInfo,
    Stepped,
    check_step_count,
    finish_checkpoints,
    step_through,
)
from unerode_cli.run.terrain_sanity import check_metres


@declared("erode", OPTIONS)
class ErosionJob(Job):
    """Run surface processes forward in time (times in years, always positive)."""

    backward: ClassVar[bool] = False

    @property
    def command(self) -> str:
        return self.COMMAND

    def plan(self, outputs: OutputPlan) -> PreparedJob:
        return plan(self, outputs)

    def run(self, planned: PreparedJob, progress: Progress) -> tuple[PreparedJob, ErosionResult]:
        return planned, run_steps(planned, progress)

    def write(self, result: tuple[PreparedJob, ErosionResult], outputs: OutputPlan) -> str:
        return write_result(*result)


@declared("unerode", OPTIONS)
class UnerosionJob(ErosionJob):
    """Run surface processes backward in time (000 §3.2): the same options, dt reversed."""

    backward: ClassVar[bool] = True


@dataclass
class PreparedJob:
    """A checked job: inputs read, processes built, every output path cleared."""

    job: ErosionJob
    terrain: Terrain
    processes: list[Process]
    parameters: dict[str, Any]
    dt: float
    steps: int
    snapshot_stride: int | None
    outputs: Outputs
    uplift: float | np.ndarray = 0.0
    checkpoints: Checkpoints = NO_CHECKPOINTS

    @property
    def signed_dt(self) -> float:
        return -self.dt if self.job.backward else self.dt


@dataclass
class ErosionResult:
    """The final elevation (m), the run's report, the snapshots written, the wall time (s) and
    how the loop ended (``stepped.finished`` False: stopped by --max-steps or a cancel)."""

    elevation: np.ndarray
    report: RunReport
    snapshots: list[Path]
    wall_s: float
    stepped: Stepped


class ErosionSteps:
    """The state of an erode/unerode run as the stepping loop drives it (:class:`Stepper`):
    the elevation (m), the processes' report and the snapshots written so far."""

    def __init__(self, prepared: PreparedJob, progress: Progress) -> None:
        job, terrain = prepared.job, prepared.terrain
        self.prepared = prepared
        guard = DivergenceGuard(terrain.elevation, max_rate(prepared.uplift))
        # the terrain keeps the start (float32 where that holds it exactly), the run its own grid
        self.elevation = take_elevation(terrain, guard)
        self.applier = StepApplier(prepared.processes, prepared.signed_dt, not job.no_substep, progress.note,
                                   guard, prepared.steps)
        self.snapshots: list[Path] = []

    def step(self, k: int) -> StepInfo:
        prepared, i = self.prepared, k + 1
        self.applier.step(self.elevation, i)
        if prepared.snapshot_stride and i % prepared.snapshot_stride == 0:
            self._snapshot(i)
        return StepInfo(f"t = {i * prepared.signed_dt:+.6g} y")

    def _snapshot(self, i: int) -> None:
        prepared, job = self.prepared, self.prepared.job
        path = snapshot_path(job.output, i // prepared.snapshot_stride)
        snap = prepared.terrain.with_elevation(self.elevation)
        snap.tags[TIME_TAG] = repr(i * prepared.signed_dt)
        save(snap, Outputs(path, prepared.outputs.options, job.overwrite or job.resume), job.command,
             _provenance(prepared), {"time_years": i * prepared.signed_dt})
        self.snapshots.append(path)

    def state(self) -> dict[str, Any]:
        report = self.applier.report
        return {"elevation": self.elevation, "steps": report.steps, "elapsed_years": report.elapsed_years,
                "substeps": report.substeps, "noted": sorted(self.applier.noted),
                "budgets": {name: [b.eroded, b.deposited, b.outflux, b.inflow]
                            for name, b in report.budgets.items()},
                "snapshots": [str(p) for p in self.snapshots],
                # a process's own state (the implicit fluvial step's deposition rates), flat, so
                # that arrays are saved as arrays
                **{f"process.{p.name}.{key}": value for p in self.prepared.processes
                   if hasattr(p, "state") for key, value in p.state().items()}}

    def restore(self, state: dict[str, Any]) -> None:
        report = self.applier.report
        self.elevation = np.array(state["elevation"], dtype=np.float64)
        report.steps, report.elapsed_years = int(state["steps"]), float(state["elapsed_years"])
        report.substeps = {name: int(n) for name, n in state["substeps"].items()}
        report.budgets = {name: Budget(*values) for name, values in state["budgets"].items()}
        self.applier.noted = set(state["noted"])
        self.snapshots = [Path(p) for p in state["snapshots"]]
        for process in self.prepared.processes:
            if hasattr(process, "restore"):
                prefix = f"process.{process.name}."
                process.restore({key[len(prefix):]: value for key, value in state.items()
                                 if key.startswith(prefix)})


def step_count(dt: float, duration: float | None, steps: int | None) -> int:
    """Steps from --duration or --steps (exactly one of them), checked: at most
    ``stepping.MAX_STEPS``."""
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {dt:g}.")
    if (duration is None) == (steps is None):
        raise InputError("give exactly one of --duration (years) and --steps.")
    if steps is not None:
        if steps < 1:
            raise InputError(f"--steps must be at least 1, got {steps}.")
        return check_step_count(steps, "--steps", "give fewer --steps (split a long run with "
                                "--max-steps and --resume) or a larger --dt")
    assert duration is not None
    if not (math.isfinite(duration) and duration > 0):
        raise InputError(f"--duration must be a positive number of years, got {duration:g}.")
    count = duration / dt
    check_step_count(count, f"--duration {duration:g} y in steps of --dt {dt:g} y")
    if abs(count - round(count)) > 1e-9 * max(1.0, count):
        raise InputError(f"--duration {duration:g} is not a whole number of --dt {dt:g} steps.")
    return max(1, round(count))


def change_preview_path(change_map: Path) -> Path:
    """``dh.tif`` → ``dh.png``: the change map's preview, written when --preview is given."""
    return change_map.with_suffix(".png")


def schemes_of(job: ErosionJob) -> tuple[str, str]:
    """(forward fluvial scheme, backward slope scheme) of --scheme, refused (InputError) when
    it names a scheme of the other direction."""
    if job.backward:
        if job.scheme in FORWARD_SCHEMES:
            raise InputError(f"--scheme {job.scheme} is a forward scheme of erode; unerode takes "
                             f"{' or '.join(BACKWARD_SCHEMES)}.")
        return "explicit", job.scheme or "limiter"
    if job.scheme in BACKWARD_SCHEMES:
        raise InputError(f"--scheme {job.scheme} sets the slope of backward steps (unerode); erode takes "
                         f"{' or '.join(FORWARD_SCHEMES)}.")
    return job.scheme or "auto", "limiter"


def plan(job: ErosionJob, plan_outputs: OutputPlan | None = None) -> PreparedJob:
    """Check the whole job before any work: options, outputs, inputs, parameters, boundaries."""
    names = parse_process_list(job.process, job.backward)
    steps = step_count(job.dt, job.duration, job.steps)
    stride = None
    if job.snapshot_every is not None:
        stride_f = job.snapshot_every / job.dt
        whole = abs(stride_f - round(stride_f)) < 1e-9 * max(1.0, stride_f)
        if not (job.snapshot_every > 0 and whole):
            raise InputError("--snapshot-every must be a positive whole multiple of --dt (years).")
        stride = max(1, round(stride_f))
        if stride > steps:
            raise InputError(f"--snapshot-every {job.snapshot_every:g} years is longer than the run, "
                             f"which lasts {steps * job.dt:g} years: no snapshot would be written; "
                             "give a shorter interval.")
    if plan_outputs is not None:
        for path in (job.source, job.params, job.dirichlet, job.inflow):
            if path is not None:
                plan_outputs.read(path)
    check_checkpoint(job.output, job.resume, job.overwrite, (job.source,))
    replace = job.overwrite or job.resume      # a resumed run rewrites what it had written
    outputs = Outputs.from_cli(job.output, job.dtype, job.cog, job.co, replace, job.preview)
    outputs.check(job.source)
    if job.snapshots_nc is not None:
        check_series(job.snapshots_nc, bool(stride), "--snapshot-every", replace, (job.source,))
    rasters = [job.change_map] if job.change_map else []
    rasters += [snapshot_path(job.output, k) for k in range(1, steps // stride + 1)] if stride else []
    for path in rasters:
        check_raster(path, outputs.options, replace, (job.source,))
    if job.change_map and job.preview:
        check_png(change_preview_path(job.change_map), replace, (job.source,))
    forward, _ = schemes_of(job)
    explicit = job.command == "erode" and forward == "explicit"
    check_command(job.command, read_header(job.source, band=job.band, georef=input_georef(job)),
                  kind="explicit" if explicit else "")
    terrain = read_terrain(job.source, band=job.band, channel=job.channel, georef=input_georef(job))
    terrain.check_valid(job.source)
    check_metres(terrain, job.source, job.force)
    outputs.check_source(terrain, job.source)
    bounds = boundaries_from_options(terrain, job.outlets, job.sea_level, job.dirichlet)
    given = given_values(job.params, job.parameter_values(), names)
    forward, scheme = schemes_of(job)
    options = {"scheme": scheme, "forward": forward, "method": job.method,
               "constraints": thermal_constraints(job.thermal_constraints),
               "inflow": inflow_for(job.inflow, names, terrain, bounds)}
    values: dict[str, Any] = {}
    parameters: dict[str, Any] = {}
    for name in names:
        for spec in REGISTRY[name].parameters:
            text = given.get(spec.name)
            parameters[spec.name] = spec.default if text is None else text
            values[spec.name] = resolve(spec, parameters[spec.name], terrain)
    processes = build_processes(names, terrain, bounds, values, options)
    uplift = values.get(UPLIFT.name, 0.0)
    prepared = PreparedJob(job, terrain, processes, parameters, job.dt, steps, stride, outputs, uplift)
    files = [job.source, job.params, job.dirichlet, job.inflow,
             *(Path(text) for text in parameters.values() if isinstance(text, str) and Path(text).is_file())]
    fingerprint = run_fingerprint(_provenance(prepared), files)
    prepared.checkpoints = Checkpoints(checkpoint_path(job.output), job.checkpoint_every, job.resume,
                                       fingerprint)
    return prepared


def run_steps(prepared: PreparedJob, progress: Progress) -> ErosionResult:
    """The time steps, on arrays, through the shared stepping loop (checkpoints, resume,
    --max-steps, cancel); numbered snapshots are written as they are reached."""
    start = time.perf_counter()
    steps = ErosionSteps(prepared, progress)
    stepped = step_through(steps, prepared.steps, progress, prepared.job.command, prepared.checkpoints,
                           prepared.job.max_steps, cells=prepared.terrain.elevation.size)
    return ErosionResult(steps.elevation, steps.applier.report, steps.snapshots,
                         time.perf_counter() - start, stepped)


def write_result(prepared: PreparedJob, result: ErosionResult) -> str:
    """Write the eroded DEM, the change map and their previews, and remove the checkpoint; the
    one-line summary. A run stopped before its end writes nothing more than its checkpoint."""
    job, terrain, report = prepared.job, prepared.terrain, result.report
    if not result.stepped.finished:
        return (f"{job.command}: stopped after step {result.stepped.done} of {prepared.steps} "
                f"(t = {report.elapsed_years:+g} y); run again with --resume to continue.")
    # the elevation is the run's own (NaN on nodata): written as it is, not copied
    output = terrain.holding(result.elevation)
    output.tags[TIME_TAG] = repr(report.elapsed_years)
    counts: dict[str, Any] = {}
    for process in prepared.processes:
        if getattr(process, "chosen", None):
            counts["fluvial_scheme"] = process.chosen          # what --scheme auto chose
        if getattr(process, "passes", 0):
            # passes of the implicit fluvial steps' deposition iteration (each converged)
            counts["fluvial_implicit_passes"] = process.passes
        if hasattr(process, "release"):
            process.release()       # the run's routing and work arrays go before the writing
    release_scratch()
    change = process_change(terrain, result.elevation, prepared, report)
    stats = {**_statistics(report, change, result.wall_s, result.snapshots), **counts}
    save(output, prepared.outputs, job.command, _provenance(prepared), stats)
    if job.change_map is not None:
        layer = terrain.holding(change)   # NaN on nodata, as both elevations are
        save(layer, Outputs(job.change_map, prepared.outputs.options, job.overwrite),
             job.command + " change", _provenance(prepared), stats, elevation_preview=False)
        if job.preview is not None:
            field_preview(change, terrain, change_preview_path(job.change_map),
                          "Δh due to the processes (m)", title=job.change_map.name, diverging=True)
    if job.snapshots_nc is not None:
        write_series(job.snapshots_nc, result.snapshots, ELEVATION,
                     f"{job.command} snapshots of {job.source.name}")
    finish_checkpoints(prepared.checkpoints, result.stepped)
    budget = sum(b.eroded for b in report.budgets.values()), sum(
        b.deposited for b in report.budgets.values())
    return (f"{job.command}: {report.steps} steps of {prepared.dt:g} y "
            f"(t = {report.elapsed_years:+g} y); removed {budget[0]:.4g} m³ from the surface, "
            f"added {budget[1]:.4g} m³; wrote {job.output}")


def process_change(
    terrain: Terrain, h: np.ndarray, prepared: PreparedJob, report: RunReport
) -> np.ndarray:
    """Δh (m) due to the processes alone: final − initial − U·t (uplift excluded); one new
    grid, no temporaries."""
    change = np.subtract(h, terrain.elevation)
    change -= prepared.uplift * report.elapsed_years
    return change


def _provenance(prepared: PreparedJob) -> dict[str, Any]:
    """The job's recorded options, what the plan derived from them (step length and count,
    direction) and the value of every parameter of its processes."""
    forward, backward = schemes_of(prepared.job)
    return {**prepared.job.provenance(), "scheme": backward if prepared.job.backward else forward,
            "dt_years": prepared.dt, "steps": prepared.steps,
            "direction": "backward" if prepared.job.backward else "forward", **prepared.parameters}


def _statistics(report: RunReport, change: np.ndarray, wall: float,
                snapshots: list[Path]) -> dict[str, Any]:
    total, largest, count = 0.0, 0.0, 0
    for first in range(0, change.shape[0], 256):   # strips of rows: no temporary grid
        strip = np.abs(change[first:first + 256])
        valid = np.isfinite(strip)
        total += float(np.sum(strip, where=valid, dtype=np.float64))
        largest = max(largest, float(np.max(strip, where=valid, initial=0.0)))
        count += int(np.count_nonzero(valid))
    return {
        "steps": report.steps,
        "substeps": report.substeps,
        "elapsed_years": report.elapsed_years,
        "mass_budget_m3": {name: {"eroded": b.eroded, "deposited": b.deposited,
                                  "outflux": b.outflux, "inflow": b.inflow, "residual": b.residual}
                           for name, b in report.budgets.items()},
        "mean_abs_change_m": total / max(count, 1),
        "max_abs_change_m": largest,
        "wall_time_s": wall,
        "snapshots": [str(p) for p in snapshots],
    }
