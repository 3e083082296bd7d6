"""The outputs of a glacier run: the eroded bed (a DEM like the input; its JSON sidecar holds the
ice-volume series and the solver statistics), the final ice thickness (``--ice``), surface
velocity (``--velocity``, two bands vx, vy in m/y, x east, y along the rows, i.e. south) and
basal speed (``--sliding``, m/y) of the final geometry, the lake depth (``--lakes``), ice
snapshots (written as the run reaches them), the timeline (``TIMELINE_COLUMNS``, one row per
step) and, along a chronology, OUT_chronology.png.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from unerode_cli.climate.chronology import YEARS_PER_KA
from unerode_cli.glacier import coupled, cycle, lakes
from unerode_cli.io.checkpoints import checkpoint_path
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.grid_rasters import write_bands
from unerode_cli.io.netcdf_files import write_series
from unerode_cli.io.netcdf_raster import ICE_THICKNESS
from unerode_cli.io.paths import atomic_path
from unerode_cli.io.provenance import history_entry, write_sidecar
from unerode_cli.run.glacial.plan import PreparedGlacierRun, chronology_png_path
from unerode_cli.run.outputs import AGE_TAG, SEA_TAG, TIME_TAG, Outputs, save
from unerode_cli.viz.glacial_chronology_plot import save_glacial_chronology_plot

if TYPE_CHECKING:
    from unerode_cli.run.glacial.steps import GlacierOutcome

#: Columns of ``--timeline``: one row per step taken (ramp steps included), at its end. The
#: ``flow_*`` columns describe the step's Blatter–Pattyn solve (empty with SIA): its L-BFGS
#: iterations, its final relative residual ‖∇E‖/‖∇E(0)‖ and whether that met the tolerance
#: (``flow_converged``: 1 or 0).
TIMELINE_COLUMNS = ("time_y", "age_ka", "ela_m", "ice_volume_m3", "ice_area_m2", "glacial_eroded_m3",
                    "ice_free_removed_m3", "lake_area_m2", "flow_iterations", "flow_residual",
                    "flow_converged")
#: Share of a run's velocity solves that may miss their tolerance before the summary says so.
UNCONVERGED_WARN_FRACTION = 0.01
#: The processes whose rock volumes the summary and the sidecar count, in their order.
ROCK_PROCESSES = ("glacial", "hillslope", "debris", "fluvial")
_PROCESS_WORDS = {"glacial": "glacial", "hillslope": "hillslope", "debris": "debris flow",
                  "fluvial": "fluvial"}
#: The column a run with a sea level adds: the sea level (m) at the step's end.
SEA_COLUMN = "sea_level_m"


def age(prepared: PreparedGlacierRun, time_y: float) -> float | None:
    """The age (ka) at ``time_y`` (y since the start) of a run along a chronology, else None."""
    run = prepared.run
    if run.from_ka is None or run.ela_chronology is None:
        return None
    return run.from_ka - time_y / YEARS_PER_KA


def timeline_row(prepared: PreparedGlacierRun, state: coupled.GlacierState, report: coupled.StepReport,
                 ice_free: cycle.IceFreeErosion | None, outlets: np.ndarray) -> dict[str, Any]:
    """One row of ``--timeline`` (``TIMELINE_COLUMNS``): the ELA of the step (mean of a map), the
    ice, the volume eroded by the glaciers in the step and carried off by the other processes
    since the start, the area of the lakes (which drain to ``outlets``); with a sea level, the
    sea level at the step's end (``SEA_COLUMN``)."""
    grid = prepared.terrain.grid
    ela = np.asarray(coupled.ela_at(prepared.ela, state.time - report.dt), dtype=np.float64)
    sea = {} if prepared.sea_level is None else {SEA_COLUMN: prepared.sea_level(state.time)}
    return {"time_y": state.time,
            "age_ka": age(prepared, state.time),
            "ela_m": float(ela[grid.valid].mean() if ela.ndim else ela),
            "ice_volume_m3": report.volume,
            "ice_area_m2": float(np.count_nonzero(state.thickness[grid.valid] > lakes.ICE_FREE_BELOW))
            * grid.cell_area,
            "glacial_eroded_m3": report.eroded,
            "ice_free_removed_m3": sum(ice_free.removed.values()) if ice_free is not None else 0.0,
            "lake_area_m2": lakes.lake_stats(lakes.lake_depth(state.bed, state.thickness, grid, outlets),
                                             grid).area_m2, **_flow_columns(report.flow), **sea}


def _flow_columns(flow: coupled.FlowField) -> dict[str, Any]:
    """The ``flow_*`` columns of a step's solve; empty cells (None) for SIA velocities."""
    if flow.lattice is None:
        return {"flow_iterations": None, "flow_residual": None, "flow_converged": None}
    return {"flow_iterations": flow.iterations, "flow_residual": flow.residual,
            "flow_converged": int(flow.converged)}


def run_seed(prepared: PreparedGlacierRun) -> int | None:
    """The seed the outputs' history records: ``--seed`` for ``--iceflow cnn`` (its network's
    initial weights), None for the ice flows that draw no random numbers."""
    return prepared.run.seed if prepared.params.iceflow == "cnn" else None


def save_layer(prepared: PreparedGlacierRun, values: np.ndarray, path: Path, unit: str,
               stats: dict[str, Any], time_years: float | None = None) -> None:
    """Write a side raster (ice thickness, basal speed, lake depth) on the DEM's grid, with sidecar."""
    layer = prepared.terrain.with_elevation(values)
    layer.tags["UNIT"] = unit
    if time_years is not None:
        layer.tags[TIME_TAG] = repr(time_years)
    save(layer, Outputs(path, prepared.write, prepared.run.replaces), prepared.command,
         prepared.parameters, stats, run_seed(prepared), elevation_preview=False)


def flow_statistics(flow: coupled.FlowField) -> dict[str, Any]:
    """The velocity solve in numbers: iterations, residual, energy, fastest surface and sliding;
    for a CNN solve in which the network predicted, whether the converged solver took over
    (``cnn_takeover``)."""
    cnn = {} if flow.takeover is None else {"cnn_takeover": flow.takeover}
    return {"iterations": flow.iterations, "evaluations": flow.evaluations, "residual": flow.residual,
            "converged": flow.converged, "energy_pa_m3_per_y": flow.energy,
            "max_surface_speed_m_per_y": float(np.max(np.hypot(*flow.surface))),
            "max_sliding_speed_m_per_y": float(np.max(np.hypot(*flow.basal))), **cnn}


def write_flow(prepared: PreparedGlacierRun, flow: coupled.FlowField, stats: dict[str, Any]) -> None:
    """``--velocity`` (two bands, m/y) and ``--sliding`` (m/y) of ``flow``, when asked."""
    run, terrain = prepared.run, prepared.terrain
    if run.velocity is not None:
        entry = history_entry(prepared.command, prepared.parameters, run_seed(prepared))
        write_bands(np.stack(flow.surface), terrain, run.velocity, prepared.write,
                    ["surface velocity vx, east (m/y)", "surface velocity vy, along rows = south (m/y)"],
                    {"UNIT": "m/y", "UNERODE_QUANTITY": "ice surface velocity"})
        write_sidecar(run.velocity, entry, stats)
    if run.sliding is not None:
        save_layer(prepared, np.hypot(*flow.basal), run.sliding, "m/y", stats)


def write_glacier(prepared: PreparedGlacierRun, outcome: GlacierOutcome) -> str:
    """Write the outputs of a finished run, remove its checkpoint and return the one-line
    summary; a stopped run (``--max-steps``, cancelled) writes nothing and says how to go on."""
    run, result = prepared.run, outcome.result
    assert run.output is not None
    if outcome.stopped:
        return (f"{prepared.command}: stopped after step {result.steps} (t = {result.state.time:g} y of "
                f"{prepared.times[-1]:g}); run again with --resume to continue.")
    final = result.state
    stats = _statistics(prepared, outcome)
    bed = prepared.terrain.with_elevation(final.bed)
    bed.tags.update(_time_tags(prepared, final.time))
    save(bed, Outputs(run.output, prepared.write, run.replaces, run.preview), prepared.command,
         prepared.parameters, stats, run_seed(prepared))
    if run.ice is not None:
        save_layer(prepared, final.thickness, run.ice, "m", stats, final.time)
    if outcome.final_flow is not None:
        write_flow(prepared, outcome.final_flow, stats)
    if run.lakes is not None and outcome.lake_depth is not None:
        save_layer(prepared, outcome.lake_depth, run.lakes, "m", stats, final.time)
    if run.timeline is not None:
        columns = list(TIMELINE_COLUMNS) + ([SEA_COLUMN] if prepared.sea_level else [])
        write_table(run.timeline, columns, outcome.timeline)
    if prepared.chronology is not None:
        _write_chronology_plot(prepared, result)
    volumes = rock_volumes(result, outcome.ice_free)
    summary = (f"{prepared.command}: {result.steps} steps to t = {final.time:g} y"
               f"{_forcing_summary(prepared, result)}; ice volume {result.volumes[-1] / 1e9:.4g} km³; "
               f"{_rock_summary(volumes)}{_solve_summary(prepared, result)}; wrote {run.output}")
    if solves_warning(result, prepared.params.flow_rtol):
        summary += "\n" + solves_warning(result, prepared.params.flow_rtol)
    if run.snapshots_nc is not None:
        write_series(run.snapshots_nc, outcome.snapshots, ICE_THICKNESS,
                     f"glaciate ice snapshots of {run.source.name}")
    checkpoint_path(run.output).unlink(missing_ok=True)
    return summary


def rock_volumes(result: coupled.RunResult, ice_free: cycle.IceFreeErosion | None) -> dict[str, Any]:
    """The rock each process took from the bed (``removed``) and laid on it (``deposited``) over
    the run, m³ by process (``ROCK_PROCESSES``), their totals, and the uplift (m³): removed −
    deposited − uplifted = −Σ Δb·dx·dy over the domain. The glaciers only remove (001 §6.1)."""
    removed = {"glacial": result.eroded}
    deposited = {"glacial": 0.0}
    if ice_free is not None:
        removed.update(ice_free.lowered)
        deposited.update(ice_free.raised)
    return {"removed_m3": removed, "deposited_m3": deposited,
            "removed_total_m3": float(sum(removed.values())),
            "deposited_total_m3": float(sum(deposited.values())),
            "uplifted_m3": ice_free.uplifted if ice_free is not None else 0.0}


def _rock_summary(volumes: dict[str, Any]) -> str:
    """"removed X m³ of rock (glacial …, hillslope …), deposited Z m³ (…)" in words."""
    def parts(by: dict[str, float]) -> str:
        return ", ".join(f"{_PROCESS_WORDS[name]} {by[name]:.4g}" for name in ROCK_PROCESSES if name in by)

    removed, deposited = volumes["removed_m3"], volumes["deposited_m3"]
    text = f"removed {volumes['removed_total_m3']:.4g} m³ of rock ({parts(removed)})"
    text += f", deposited {volumes['deposited_total_m3']:.4g} m³"
    if len(deposited) > 1 and volumes["deposited_total_m3"] > 0:
        text += f" ({parts(deposited)})"
    if volumes["uplifted_m3"]:
        text += f", uplifted {volumes['uplifted_m3']:.4g} m³"
    return text


def _solve_summary(prepared: PreparedGlacierRun, result: coupled.RunResult) -> str:
    """"; N velocity solves to a residual of rtol (I iterations), K missed it" ("" without any),
    and for ``--iceflow cnn`` how many of the solves the network predicted met it on its own
    (prediction + refinement) and in how many the converged solver took over."""
    if not result.solves:
        return ""
    text = (f"; {result.solves} velocity solves to a residual of {prepared.params.flow_rtol:g} "
            f"({result.iterations} iterations), {result.unconverged} missed it")
    if prepared.params.iceflow == "cnn":
        text += (f" (CNN: {result.cnn_met} of its {result.cnn_solves} "
                 f"predictions met it on their own, the converged solver took over {result.cnn_takeovers})")
    return text


def solves_warning(result: coupled.RunResult, rtol: float) -> str:
    """The sentence a run gets when more than ``UNCONVERGED_WARN_FRACTION`` of its velocity
    solves missed their tolerance ``rtol``; "" otherwise."""
    if not result.solves or result.unconverged <= UNCONVERGED_WARN_FRACTION * result.solves:
        return ""
    return (f"warning: {result.unconverged} of {result.solves} velocity solves "
            f"({result.unconverged / result.solves:.0%}) ended above the tolerance {rtol:g} "
            f"(largest residual {result.max_residual:.2g}), so the velocities and erosion of this run "
            "are not converged.")


def _statistics(prepared: PreparedGlacierRun, outcome: GlacierOutcome) -> dict[str, Any]:
    """The sidecar's statistics of a finished run: the ice-volume series, totals of the loop, its
    wall time by part, the ice-free processes' volumes, the final flow and the lakes."""
    result, terrain = outcome.result, prepared.terrain
    lowering = (terrain.elevation - result.state.bed)[terrain.grid.valid]
    stats: dict[str, Any] = {
        "steps": result.steps,
        "elapsed_years": result.state.time,
        "ice_volume_series": {"time_years": result.times, "ice_volume_m3": result.volumes},
        "final_ice_volume_m3": result.volumes[-1],
        "eroded_volume_m3": result.eroded,
        "max_erosion_m": float(lowering.max()) if lowering.size else 0.0,
        "transport_substeps": result.substeps,
        "rejected_steps": result.retries,
        "velocity_solves": result.solves,
        "velocity_resolves": result.resolves,
        "flow_iterations": result.iterations,
        "energy_evaluations": result.evaluations,
        "flow_rtol": prepared.params.flow_rtol,
        "unconverged_solves": result.unconverged,
        "unconverged_fraction": result.unconverged / result.solves if result.solves else 0.0,
        "max_flow_residual": result.max_residual,
        **_cnn_statistics(prepared, result),
        "rock_volumes": rock_volumes(result, outcome.ice_free),
        "wall_time_s": outcome.wall,
        "snapshots": [str(p) for p in outcome.snapshots],
    }
    if outcome.note:
        stats["note"] = outcome.note
    # the run's "other" adds its set-up to the loop's own (coupled.run), so the parts add up to the wall
    parts = dict(result.seconds)
    parts["other"] = max(0.0, outcome.wall - sum(v for k, v in parts.items() if k != "other"))
    stats["wall_time_by_part_s"] = parts
    if outcome.ice_free is not None:
        stats["ice_free_removed_m3"] = dict(outcome.ice_free.removed)
        stats["ice_free_wall_time_s"] = dict(outcome.ice_free.seconds)
    if outcome.final_flow is not None:
        stats["final_flow"] = flow_statistics(outcome.final_flow)
    if outcome.lake_depth is not None:
        stats["lakes"] = asdict(lakes.lake_stats(outcome.lake_depth, terrain.grid))
    return stats


def _cnn_statistics(prepared: PreparedGlacierRun, result: coupled.RunResult) -> dict[str, Any]:
    """For ``--iceflow cnn``: the velocity solves of the accepted steps in which the network
    predicted (``cnn_solves``), those whose prediction and refinement met ``flow_rtol`` on their own
    (``cnn_met_tolerance``) and those the converged solver took over (``cnn_takeovers``); empty for
    the other ice flows."""
    if prepared.params.iceflow != "cnn":
        return {}
    return {"cnn_solves": result.cnn_solves, "cnn_met_tolerance": result.cnn_met,
            "cnn_takeovers": result.cnn_takeovers}


def _time_tags(prepared: PreparedGlacierRun, time_y: float) -> dict[str, str]:
    """Tags of the bed at ``time_y`` (y): the time, and along a chronology the age (ka) and the
    sea level (m) when the run has one (as climate-run tags its outputs)."""
    tags = {TIME_TAG: repr(time_y)}
    at = age(prepared, time_y)
    if at is not None:
        tags[AGE_TAG] = repr(at)
    if prepared.sea_level is not None:
        tags[SEA_TAG] = repr(prepared.sea_level(time_y))
    return tags


def _forcing_summary(prepared: PreparedGlacierRun, result: coupled.RunResult) -> str:
    """The forcings of a run along a chronology in words: the ELA range (m) over the steps and,
    with a sea level, its range (m); empty for other runs."""
    start = age(prepared, 0.0)
    if start is None:
        return ""
    times = np.asarray(result.times)
    ela = [float(np.mean(coupled.ela_at(prepared.ela, t))) for t in times[:-1]]
    text = f" from {start:g} to {age(prepared, times[-1]):g} ka (ELA {min(ela):.0f}–{max(ela):.0f} m"
    if prepared.sea_level is not None:
        sea = [prepared.sea_level(t) for t in times]
        text += f", sea level {min(sea):+.1f} to {max(sea):+.1f} m"
    return text + ")"


def _write_chronology_plot(prepared: PreparedGlacierRun, result: coupled.RunResult) -> None:
    """OUT_chronology.png: the proxy, the ELA at the start of each step and the ice volume."""
    run, series = prepared.run, prepared.chronology
    assert series is not None and run.output is not None and run.from_ka is not None
    times = np.asarray(result.times)
    ela = [float(np.mean(coupled.ela_at(prepared.ela, t))) for t in times]
    with atomic_path(chronology_png_path(run.output)) as tmp:
        save_glacial_chronology_plot(tmp, series.age_ka, series.value, f"{series.name} ({series.unit})",
                                     run.from_ka - times / YEARS_PER_KA, np.array(ela),
                                     np.array(result.volumes), title=run.output.name)
