"""The outputs of a climate-run of the runner's processes: the DEM at ``--to`` and the snapshots,
tagged with age (ka), sea level (m), climate phase and time (y), OUTPUT_timeline.csv (one row per
step), OUTPUT_chronology.png, and the summary."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from unerode_cli.io.checkpoints import checkpoint_path
from unerode_cli.io.coarse_runs import fluxes_folder
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.netcdf_files import write_series
from unerode_cli.io.netcdf_raster import ELEVATION
from unerode_cli.io.paths import atomic_path
from unerode_cli.jobs.climate_run.forcing import chronology_png_path, snapshot_path, timeline_path
from unerode_cli.run.outputs import AGE_TAG, PHASE_TAG, SEA_TAG, TIME_TAG, Outputs, save
from unerode_cli.viz.chronology_plot import save_chronology_plot

if TYPE_CHECKING:
    from unerode_cli.jobs.climate_run.plan import PreparedClimateRun
    from unerode_cli.jobs.climate_run.steps import ClimateResult


def save_state(prepared: PreparedClimateRun, h: np.ndarray, k: int, path: Path,
               statistics: dict[str, Any] | None = None) -> None:
    """Write the elevation ``h`` (m) after step k (0-based) to ``path``: the output (with
    ``statistics`` of the whole run) or a snapshot, tagged with the step's end age, sea level
    and phase."""
    job, forcing = prepared.job, prepared.forcing
    state = prepared.terrain.with_elevation(h)
    age = float(forcing.end_ka[k])
    state.tags.update({AGE_TAG: repr(age), SEA_TAG: repr(float(forcing.sea_end[k])),
                       PHASE_TAG: str(forcing.phase[k]),
                       TIME_TAG: repr((age - job.from_ka) * -1000.0)})
    final = path == job.output
    outputs = prepared.outputs if final else Outputs(path, prepared.outputs.options, True)
    stats = {"age_ka": age, "sea_level_m": float(forcing.sea_end[k]), "phase": str(forcing.phase[k]),
             "boundaries": prepared.base_levels.counts(), **(statistics or {})}
    save(state, outputs, job.COMMAND, provenance(prepared), stats)


def provenance(prepared: PreparedClimateRun) -> dict[str, Any]:
    """The history's parameters: the recorded options and the parameter values given."""
    job = prepared.job
    given = {name: text for name, text in job.parameter_values().items() if text is not None}
    return {**job.provenance(), **given}


def write_climate(prepared: PreparedClimateRun, result: ClimateResult) -> str:
    """Write the outputs of a finished run, remove its checkpoint, and return the one-line
    summary; a run stopped before its end (``--max-steps``, cancelled) writes nothing more and
    says how to go on."""
    job, forcing = prepared.job, prepared.forcing
    if result.done < prepared.steps:
        return (f"{job.COMMAND}: stopped after step {result.done} of {prepared.steps} "
                f"({forcing.end_ka[result.done - 1]:g} ka); run again with --resume to continue.")
    rows = result.timeline
    statistics = {"steps": prepared.steps, "wall_time_s": result.wall,
                  "eroded_m3": float(sum(r["eroded_m3"] for r in rows)),
                  "deposited_m3": float(sum(r["deposited_m3"] for r in rows)),
                  **({"inflow_m3": float(sum(r["inflow_m3"] for r in rows))}
                     if prepared.inflow is not None else {}),
                  "snapshots": [str(snapshot_path(job.output, a)) for a in job.snapshot_ages]}
    save_state(prepared, result.elevation, prepared.steps - 1, job.output, statistics)
    _write_timeline(timeline_path(job.output), rows)
    with atomic_path(chronology_png_path(job.output)) as tmp:
        save_chronology_plot(tmp, forcing.end_ka, forcing.phase, forcing.sea_end,
                             prepared.chronology.age_ka, prepared.chronology.value,
                             f"{prepared.chronology.name} ({prepared.chronology.unit})",
                             job.snapshot_ages, title=job.output.name)
    if job.snapshots_nc is not None:
        write_series(job.snapshots_nc, [snapshot_path(job.output, a) for a in job.snapshot_ages], ELEVATION,
                     f"climate-run snapshots of {job.source.name}")
    checkpoint_path(job.output).unlink(missing_ok=True)
    return (f"{job.COMMAND}: {prepared.steps} steps of {job.dt:g} y from {job.from_ka:g} to "
            f"{job.to_ka:g} ka; wrote {job.output}, {timeline_path(job.output).name}, "
            f"{chronology_png_path(job.output).name} and {len(job.snapshot_ages)} snapshot(s)"
            + (f", and the nesting rasters in {fluxes_folder(job.output).name}/" if job.write_fluxes else "")
            + f"; {prepared.base_levels.summary()}"
            + (f"; {prepared.nesting.summary()}" if prepared.nesting is not None else ""))


def _write_timeline(path: Path, rows: list[dict[str, Any]]) -> None:
    """The timeline: every column any row has, in order of first appearance."""
    columns: list[str] = []
    for row in rows:
        columns += [c for c in row if c not in columns]
    write_table(path, columns, rows)
