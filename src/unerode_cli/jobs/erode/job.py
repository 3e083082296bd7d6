"""The `erode` / `unerode` job: plan (check everything, read inputs), run on arrays, write."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.paths import OutputPlan
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.erode.options import OPTIONS
from unerode_cli.processes.parameters import UPLIFT
from unerode_cli.run.boundaries import boundaries_from_options
from unerode_cli.run.declare import declared
from unerode_cli.run.divergence import DivergenceGuard, max_rate
from unerode_cli.run.job import Job, Progress
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
from unerode_cli.run.runner import Process, RunReport, run


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

    @property
    def signed_dt(self) -> float:
        return -self.dt if self.job.backward else self.dt


@dataclass
class ErosionResult:
    """The final elevation (m), the run's report, the snapshots written and the wall time (s)."""

    elevation: np.ndarray
    report: RunReport
    snapshots: list[Path]
    wall_s: float


def step_count(dt: float, duration: float | None, steps: int | None) -> int:
    """Steps from --duration or --steps (exactly one of them), checked."""
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {dt:g}.")
    if (duration is None) == (steps is None):
        raise InputError("give exactly one of --duration (years) and --steps.")
    if steps is not None:
        if steps < 1:
            raise InputError(f"--steps must be at least 1, got {steps}.")
        return steps
    assert duration is not None
    if not (math.isfinite(duration) and duration > 0):
        raise InputError(f"--duration must be a positive number of years, got {duration:g}.")
    count = duration / dt
    if abs(count - round(count)) > 1e-9 * max(1.0, count):
        raise InputError(f"--duration {duration:g} is not a whole number of --dt {dt:g} steps.")
    return max(1, round(count))


def change_preview_path(change_map: Path) -> Path:
    """``dh.tif`` → ``dh.png``: the change map's preview, written when --preview is given."""
    return change_map.with_suffix(".png")


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
    if plan_outputs is not None:
        for path in (job.source, job.params, job.dirichlet, job.inflow):
            if path is not None:
                plan_outputs.read(path)
    outputs = Outputs.from_cli(job.output, job.dtype, job.cog, job.co, job.overwrite, job.preview)
    outputs.check(job.source)
    rasters = [job.change_map] if job.change_map else []
    rasters += [snapshot_path(job.output, k) for k in range(1, steps // stride + 1)] if stride else []
    for path in rasters:
        check_raster(path, outputs.options, job.overwrite, (job.source,))
    if job.change_map and job.preview:
        check_png(change_preview_path(job.change_map), job.overwrite, (job.source,))
    terrain = read_terrain(job.source, band=job.band, channel=job.channel)
    terrain.check_valid(job.source)
    outputs.check_source(terrain, job.source)
    bounds = boundaries_from_options(terrain, job.outlets, job.sea_level, job.dirichlet)
    given = given_values(job.params, job.parameter_values(), names)
    options = {"scheme": job.scheme, "method": job.method,
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
    return PreparedJob(job, terrain, processes, parameters, job.dt, steps, stride, outputs, uplift)


def run_steps(prepared: PreparedJob, progress: Progress) -> ErosionResult:
    """The time steps, on arrays (numbered snapshots are written as they are reached)."""
    job, terrain = prepared.job, prepared.terrain
    start = time.perf_counter()
    snapshots: list[Path] = []
    progress.start(prepared.steps, job.command)

    def after_step(i: int, h: np.ndarray) -> None:
        if prepared.snapshot_stride and i % prepared.snapshot_stride == 0:
            path = snapshot_path(job.output, i // prepared.snapshot_stride)
            snap = terrain.with_elevation(h)
            snap.tags[TIME_TAG] = repr(i * prepared.signed_dt)
            save(snap, Outputs(path, prepared.outputs.options, job.overwrite), job.command,
                 _provenance(prepared), {"time_years": i * prepared.signed_dt})
            snapshots.append(path)
        progress.advance(f"t = {i * prepared.signed_dt:+.6g} y")

    guard = DivergenceGuard(terrain.elevation, max_rate(prepared.uplift))
    h, report = run(terrain.elevation, prepared.processes, prepared.signed_dt, prepared.steps,
                    not job.no_substep, after_step, progress.note, guard)
    return ErosionResult(h, report, snapshots, time.perf_counter() - start)


def write_result(prepared: PreparedJob, result: ErosionResult) -> str:
    """Write the eroded DEM, the change map and their previews; the one-line summary."""
    job, terrain, report = prepared.job, prepared.terrain, result.report
    output = terrain.with_elevation(result.elevation)
    output.tags[TIME_TAG] = repr(report.elapsed_years)
    change = process_change(terrain, result.elevation, prepared, report)
    stats = _statistics(report, change, result.wall_s, result.snapshots)
    save(output, prepared.outputs, job.command, _provenance(prepared), stats)
    if job.change_map is not None:
        layer = terrain.with_elevation(change)
        save(layer, Outputs(job.change_map, prepared.outputs.options, job.overwrite),
             job.command + " change", _provenance(prepared), stats, elevation_preview=False)
        if job.preview is not None:
            field_preview(change, terrain, change_preview_path(job.change_map),
                          "Δh due to the processes (m)", title=job.change_map.name, diverging=True)
    budget = sum(b.eroded for b in report.budgets.values()), sum(
        b.deposited for b in report.budgets.values())
    return (f"{job.command}: {report.steps} steps of {prepared.dt:g} y "
            f"(t = {report.elapsed_years:+g} y); removed {budget[0]:.4g} m³ from the surface, "
            f"added {budget[1]:.4g} m³; wrote {job.output}")


def process_change(
    terrain: Terrain, h: np.ndarray, prepared: PreparedJob, report: RunReport
) -> np.ndarray:
    """Δh (m) due to the processes alone: final − initial − U·t (uplift excluded)."""
    return h - terrain.elevation - prepared.uplift * report.elapsed_years


def _provenance(prepared: PreparedJob) -> dict[str, Any]:
    """The job's recorded options, what the plan derived from them (step length and count,
    direction) and the value of every parameter of its processes."""
    return {**prepared.job.provenance(), "dt_years": prepared.dt, "steps": prepared.steps,
            "direction": "backward" if prepared.job.backward else "forward", **prepared.parameters}


def _statistics(report: RunReport, change: np.ndarray, wall: float,
                snapshots: list[Path]) -> dict[str, Any]:
    valid = np.isfinite(change)
    return {
        "steps": report.steps,
        "substeps": report.substeps,
        "elapsed_years": report.elapsed_years,
        "mass_budget_m3": {name: {"eroded": b.eroded, "deposited": b.deposited,
                                  "outflux": b.outflux, "inflow": b.inflow, "residual": b.residual}
                           for name, b in report.budgets.items()},
        "mean_abs_change_m": float(np.abs(change[valid]).mean()),
        "max_abs_change_m": float(np.abs(change[valid]).max()),
        "wall_time_s": wall,
        "snapshots": [str(p) for p in snapshots],
    }
