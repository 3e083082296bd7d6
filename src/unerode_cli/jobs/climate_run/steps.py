"""The steps of a climate-run of the runner's processes (000 §5): per-step parameters from the
schedule and the sea level, boundary nodes set to their base level at the step's end, one
runner step, a timeline row; snapshots and nesting rasters as their ages are reached. The loop,
its progress, checkpoints, resume and stop are those of every time-stepping job
(``run.stepping``).

Before each step the boundary nodes are set to their base level at the step's end age
(``run.boundaries.BaseLevels``), e.g. h_b(t) = h_b(start) + (sea(t) − sea(start)) on the coast,
so that after each step they follow it exactly.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from unerode_cli.climate.schedule import DOWNSTREAM_K_D
from unerode_cli.io.checkpoints import checkpoint_path
from unerode_cli.io.coarse_runs import fluxes_folder, write_state
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.climate_run.forcing import snapshot_path
from unerode_cli.jobs.climate_run.outputs import save_state
from unerode_cli.jobs.climate_run.plan import PreparedClimateRun
from unerode_cli.processes.fluvial import Inflow
from unerode_cli.processes.parameters import UPLIFT
from unerode_cli.run.divergence import DivergenceGuard, max_rate
from unerode_cli.run.job import Progress
from unerode_cli.run.outputs import AGE_TAG, SEA_TAG
from unerode_cli.run.registry import build_processes, thermal_constraints
from unerode_cli.run.runner import run
from unerode_cli.run.stepping import Checkpoints, StepInfo, step_through

DIVERGENCE_HINT = "lower --dt or the rates (K, k_th), or drop a process that runs away backward"


@dataclass
class ClimateResult:
    """The elevation (m) after ``done`` steps, the timeline rows and the wall-clock seconds of
    this invocation."""

    elevation: np.ndarray
    done: int
    timeline: list[dict[str, Any]]
    wall: float


def step_values(prepared: PreparedClimateRun, k: int) -> tuple[dict[str, Any], dict[str, float]]:
    """Parameter values of step k (0-based), and the scalars written to its timeline row.

    The run's own values (numbers or rasters; U from the uplift table's mean over the step,
    ``climate.uplift``) with the phase's put over them (``Schedule.apply``: a number replaced, a
    raster scaled by v_phase / v_interglacial), and k_d inside the downstream region following
    sea level (000 §5.2). The row holds the phase's values of the run's parameters, the
    downstream k_d (m/y) when the run has k_d, and the uplift used, ``uplift_m_per_y`` (m/y, the
    mean over the DEM's cells for a raster).
    """
    forcing = prepared.forcing
    phase, sea = str(forcing.phase[k]), float(forcing.sea_mid[k])
    ordinary = dict(prepared.base_values)
    if prepared.uplift is not None and UPLIFT.name in ordinary:
        start = 2.0 * float(forcing.mid_ka[k]) - float(forcing.end_ka[k])
        ordinary[UPLIFT.name] = prepared.uplift.over(start, float(forcing.end_ka[k]))
    values = prepared.schedule.apply(phase, ordinary)
    scheduled = prepared.schedule.values(phase, sea)
    row = {name: value for name, value in scheduled.items() if name in values}
    if "k_d" in values:
        row[DOWNSTREAM_K_D] = scheduled[DOWNSTREAM_K_D]
        if prepared.downstream is not None:
            values["k_d"] = np.where(prepared.downstream, scheduled[DOWNSTREAM_K_D], values["k_d"])
    if UPLIFT.name in values:
        row["uplift_m_per_y"] = _domain_mean(values[UPLIFT.name], prepared.terrain)
    return values, row


def _domain_mean(value: float | np.ndarray, terrain: Terrain) -> float:
    """A number, or the mean of a raster over the DEM's cells (nodata excluded)."""
    if np.ndim(value) == 0:
        return float(value)
    return float(np.mean(np.asarray(value)[~terrain.nodata_mask]))


def _processes(prepared: PreparedClimateRun, values: dict[str, Any], sea_end: float,
               inflow: Inflow | None) -> list:
    """The processes of one step, with the boundaries at the step's end sea level."""
    job = prepared.job
    bounds = prepared.base_levels.boundaries(sea_end if job.sea_outlets else None)
    options = {"scheme": job.scheme, "method": job.method,
               "constraints": thermal_constraints(job.thermal_constraints), "inflow": inflow}
    return build_processes(prepared.names, prepared.terrain, bounds, values, options)


def run_steps(prepared: PreparedClimateRun, progress: Progress) -> ClimateResult:
    """Run (or resume) the steps (``run.stepping``), until the end, ``--max-steps`` or a
    cancelled progress."""
    job = prepared.job
    start_time = time.perf_counter()
    stepper = _ClimateStepper(prepared, progress)
    checkpoints = Checkpoints(checkpoint_path(job.output), job.checkpoint_every, job.resume,
                              prepared.fingerprint)
    stepped = step_through(stepper, prepared.steps, progress, job.COMMAND, checkpoints, job.max_steps,
                           cells=stepper.h.size)
    return ClimateResult(stepper.h, stepped.done, stepper.rows, time.perf_counter() - start_time)


class _ClimateStepper:
    """The state of a climate-run between steps (``run.stepping.Stepper``): the elevation (m)
    and the timeline rows so far."""

    def __init__(self, prepared: PreparedClimateRun, progress: Progress) -> None:
        self.prepared, self.progress = prepared, progress
        self.h = np.array(prepared.terrain.elevation, dtype=np.float64, copy=True)
        self.rows: list[dict[str, Any]] = []
        self.snapshots = {round(a, 9) for a in prepared.job.snapshot_ages}
        self.noted: set[str] = set()
        self.guard = DivergenceGuard(prepared.terrain.elevation, hint=DIVERGENCE_HINT)

    def state(self) -> dict[str, Any]:
        return {"elevation": self.h, "timeline": self.rows}

    def restore(self, state: dict[str, Any]) -> None:
        self.h = np.array(state["elevation"], dtype=np.float64)
        self.rows = list(state["timeline"])

    def step(self, k: int) -> StepInfo:
        """Step k (0-based): the forcing and parameters of its ages, the boundary nodes at their
        base level of its end, one runner step, its timeline row, snapshot and nesting rasters."""
        prepared = self.prepared
        job, terrain, forcing = prepared.job, prepared.terrain, prepared.forcing
        signed_dt = (-1.0 if job.backward else 1.0) * job.dt
        values, scheduled = step_values(prepared, k)
        self.guard.uplift_rate = max(self.guard.uplift_rate, max_rate(values.get(UPLIFT.name, 0.0)))
        sea_end = float(forcing.sea_end[k])
        prepared.base_levels.set_levels(self.h, terrain.elevation, sea_end - forcing.sea_start,
                                        float(forcing.end_ka[k]), values.get("uplift", 0.0), signed_dt)
        before = self.h.copy()
        inflow = None if prepared.inflow is None else prepared.inflow.at(float(forcing.mid_ka[k]))
        processes = _processes(prepared, values, sea_end, inflow)
        self.h, report = run(self.h, processes, signed_dt, 1, not job.no_substep, None,
                             lambda message: self._note_once(message, k))
        self.guard.check(self.h, (k + 1) * signed_dt, f"at {forcing.end_ka[k]:g} ka")
        change = np.abs(self.h - before)[~terrain.nodata_mask]
        self.rows.append({"age_ka": float(forcing.end_ka[k]), "phase": str(forcing.phase[k]),
                          "sea_level_m": sea_end, **scheduled,
                          "eroded_m3": sum(b.eroded for b in report.budgets.values()),
                          "deposited_m3": sum(b.deposited for b in report.budgets.values()),
                          **(_inflow_columns(report, inflow) if inflow is not None else {}),
                          "mean_abs_dh_m": float(change.mean()), "max_abs_dh_m": float(change.max())})
        if round(float(forcing.end_ka[k]), 9) in self.snapshots:
            save_state(prepared, self.h, k, snapshot_path(job.output, float(forcing.end_ka[k])))
        if job.write_fluxes:
            _write_fluxes(prepared, processes, k, before, self.h, self.snapshots)
        return StepInfo(f"{forcing.end_ka[k]:.6g} ka, {forcing.phase[k]}, sea {sea_end:+.1f} m")

    def _note_once(self, message: str, k: int) -> None:
        """Pass a sub-stepping note on at its first climate step only (one per process)."""
        key = message.split(" (", 1)[0]
        if key not in self.noted:
            self.noted.add(key)
            self.progress.note(f"{message[:-1]}, first at {self.prepared.forcing.end_ka[k]:g} ka; "
                               "no further note.")


def _inflow_columns(report: Any, inflow: Inflow) -> dict[str, float]:
    """Timeline columns of a run with inflow: the sediment volume brought in over the step (m³,
    negative backward) and the water discharge entering (m³/y, at the step's middle age)."""
    return {"inflow_m3": sum(b.inflow for b in report.budgets.values()),
            "inflow_discharge_m3_per_y": float(inflow.discharge.sum())}


def _write_fluxes(prepared: PreparedClimateRun, processes: list, k: int, before: np.ndarray,
                  h: np.ndarray, snapshots: set[float]) -> None:
    """The nesting rasters after step k: at the start age with the first step's Q and Q_s
    (computed on the input DEM), and at each snapshot age and the end with those of the step
    that ends there (computed on the surface one step earlier)."""
    job, forcing = prepared.job, prepared.forcing
    fluvial = next(p for p in processes if p.name == "fluvial")
    discharge, sediment_flux = fluvial.last_fluxes()
    folder = fluxes_folder(job.output)
    end = float(forcing.end_ka[k])
    if k == 0:
        write_state(folder, prepared.terrain.with_elevation(before), job.from_ka, discharge,
                    sediment_flux, {AGE_TAG: repr(job.from_ka), SEA_TAG: repr(forcing.sea_start)})
    if round(end, 9) in snapshots or k + 1 == prepared.steps:
        write_state(folder, prepared.terrain.with_elevation(h), end, discharge, sediment_flux,
                    {AGE_TAG: repr(end), SEA_TAG: repr(float(forcing.sea_end[k]))})
