"""The plan of a climate-run of the runner's processes: every option, input and output checked,
every input read, the forcing of each step computed from the chronology (:func:`plan`); no step.

Boundary nodes follow their base level (``run.boundaries.BaseLevels``): the sea for the coast,
else fixed, uplifted, from a table or from a coarse run (``--inflow-from``, 000 §6.3.1).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from unerode_cli.climate.chronology import Series
from unerode_cli.climate.phases import PHASES
from unerode_cli.climate.schedule import Schedule, downstream_mask
from unerode_cli.climate.uplift import FACTOR_COLUMN, RATE_COLUMN, UpliftHistory
from unerode_cli.errors import InputError
from unerode_cli.glacier import cycle
from unerode_cli.io.checkpoints import check_checkpoint
from unerode_cli.io.chronology_files import read_age_table
from unerode_cli.io.coarse_runs import check_fluxes_folder, coarse_run_folder, fluxes_folder, read_coarse_run
from unerode_cli.io.grid_rasters import load_on_grid
from unerode_cli.io.netcdf_files import check_series
from unerode_cli.io.paths import OutputPlan, check_output
from unerode_cli.io.rasters import read_header, read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.jobs.climate_run.forcing import (
    Forcing,
    chronology_png_path,
    forcing,
    read_sea_level,
    snapshot_path,
    step_count,
    timeline_path,
)
from unerode_cli.processes.inflow import InflowHistory
from unerode_cli.processes.parameters import UPLIFT
from unerode_cli.run.boundaries import COARSE, BaseLevels, base_levels_from_options, edge_base_table
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.fingerprint import run_fingerprint
from unerode_cli.run.glacial.options import MODEL_PARAMETERS
from unerode_cli.run.job import Progress
from unerode_cli.run.memory import check_command
from unerode_cli.run.nesting import Nesting, crossing_outlets, nest
from unerode_cli.run.outputs import Outputs, check_png, check_raster
from unerode_cli.run.parameter_maps import resolve
from unerode_cli.run.registry import REGISTRY, given_values, inflow_history_for, parse_process_list
from unerode_cli.run.terrain_sanity import check_metres

if TYPE_CHECKING:
    from unerode_cli.jobs.climate_run.job import ClimateJob

#: Parameters only the glacier model takes: its mass balance (001 Eq. 2; the ELA comes from the
#: chronology), glacial erosion (001 §6.1) and the k_f of its rivers (001 §6.3).
GLACIER_ONLY_PARAMETERS = (*MODEL_PARAMETERS, cycle.K_F)
#: Options that do not change a run's result: left out of its fingerprint.
_NOT_FINGERPRINTED = ("resume", "max_steps", "overwrite", "preview", "checkpoint_every", "report")


@dataclass
class PreparedClimateRun:
    """A checked climate-run: the DEM, the processes' names and base parameter values (numbers
    or rasters), the schedule by phase, the forcing of each step, the boundary nodes' base
    levels, the downstream region (bool[ny, nx], or None), the step count, the output, the
    chronology, the fingerprint, and the uplift table, inflow and nesting when given."""

    job: ClimateJob
    terrain: Terrain
    names: list[str]
    base_values: dict[str, Any]
    schedule: Schedule
    forcing: Forcing
    base_levels: BaseLevels
    downstream: np.ndarray | None
    steps: int
    outputs: Outputs
    chronology: Series
    fingerprint: str
    uplift: UpliftHistory | None = None
    inflow: InflowHistory | None = None
    nesting: Nesting | None = None


def plan(job: ClimateJob, plan_outputs: OutputPlan | None = None, progress: Progress | None = None
         ) -> PreparedClimateRun:
    """Check everything before the first step: options, outputs, inputs, chronology range;
    ``progress`` hears what was changed in the tables as read (rows left out or sorted)."""
    on_note = progress.note if progress is not None else None
    names = parse_process_list(job.process, job.backward)
    _check_no_glacier_options(job)
    steps = step_count(job)
    if plan_outputs is not None:
        for path in input_files(job):
            plan_outputs.read(path)
    outputs = Outputs.from_cli(job.output, job.dtype, job.cog, job.co, job.replaces, job.preview)
    outputs.check(job.source)
    _check_outputs(job, names, steps, outputs)
    check_command("climate-run", read_header(job.source, georef=input_georef(job)))
    terrain = read_terrain(job.source, georef=input_georef(job))
    terrain.check_valid(job.source)
    check_metres(terrain, job.source, job.force)
    outputs.check_source(terrain, job.source)
    chronology, sea = read_sea_level(job, on_note)
    run_forcing = forcing(job, steps, sea)
    try:
        schedule = Schedule.from_mapping(read_yaml_mapping(
            job.schedule_file, "the schedule file", "a mapping of phases to parameters",
        )) if job.schedule_file else Schedule()
    except ValueError as exc:
        raise InputError(f"{job.schedule_file}: {exc}") from None
    given = given_values(None, job.parameter_values(), names)
    table = given.pop(UPLIFT.name) if is_table(given.get(UPLIFT.name)) else None
    base = {}
    for name in names:
        for spec in REGISTRY[name].parameters:
            text = given.get(spec.name)
            files = "a raster or a CSV table" if spec.name == UPLIFT.name else "a raster"
            base[spec.name] = resolve(spec, spec.default if text is None else text, terrain, files)
    _check_scalable(job, schedule, base)
    uplift = _uplift_history(job, table, terrain, schedule)
    sea_start = run_forcing.sea_start if job.sea_outlets else None
    coarse = read_coarse_run(job.inflow_from) if job.inflow_from is not None else None
    crossing = (crossing_outlets(coarse, terrain, (job.from_ka, job.to_ka))
                if coarse is not None and job.outlets is None else None)
    edges = job.outlets or ("none" if crossing is not None else "all")
    base_levels = base_levels_from_options(terrain, edges, job.dirichlet, job.coast, job.edge_base_choice,
                                           sea_start, (job.from_ka, job.to_ka), crossing)
    downstream = None
    if job.downstream_mask is not None or job.downstream_below is not None:
        mask = (load_on_grid(job.downstream_mask, terrain, "downstream mask") != 0
                if job.downstream_mask else None)
        downstream = downstream_mask(terrain.elevation, job.downstream_below, mask)
    start_outlets = base_levels.boundaries(sea_start)
    inflow = inflow_history_for(job.inflow, names, terrain, start_outlets)
    nesting = None
    if coarse is not None:
        nodes = base_levels.edge if base_levels.edge_base == COARSE else np.zeros(terrain.shape, bool)
        nesting = nest(coarse, terrain,
                       start_outlets.outlets(terrain.elevation, terrain), nodes,
                       (job.from_ka, job.to_ka))
        inflow = nesting.inflow
        if base_levels.edge_base == COARSE:
            base_levels = dataclasses.replace(base_levels, node_levels=nesting.levels)
    elif inflow is not None and not (inflow.covers(job.from_ka) and inflow.covers(job.to_ka)):
        raise InputError(f"the inflow table {job.inflow} covers {inflow.span_ka[0]:g}–"
                         f"{inflow.span_ka[1]:g} ka, not the whole run from {job.from_ka:g} to "
                         f"{job.to_ka:g} ka.")
    return PreparedClimateRun(job, terrain, names, base, schedule, run_forcing, base_levels, downstream,
                              steps, outputs, chronology, _fingerprint(job), uplift, inflow, nesting)


def _check_outputs(job: ClimateJob, names: list[str], steps: int, outputs: Outputs) -> None:
    """Clear, before any work, the snapshots (each at the end of a step), the timeline, the
    nesting rasters, the chronology plot and the checkpoint."""
    low, high = sorted((job.from_ka, job.to_ka))
    span = f"{job.from_ka:g} → {job.to_ka:g} ka"
    for age in job.snapshot_ages:
        if not low - 1e-9 <= age <= high + 1e-9:
            raise InputError(f"snapshot age {age:g} ka is outside the run, which spans {span}; "
                             "give ages within it.")
        k = round(abs(age - job.from_ka) * 1000.0 / job.dt)
        step_end = round(job.from_ka + (1 if job.backward else -1) * k * job.dt / 1000.0, 9)
        if not 1 <= k <= steps or round(age, 9) != step_end:
            raise InputError(f"snapshot age {age:g} ka is not the end of a step of the run "
                             f"({span} by {job.dt:g} years).")
    check_checkpoint(job.output, job.resume, job.overwrite, (job.source,))
    for path in [snapshot_path(job.output, a) for a in job.snapshot_ages]:
        check_raster(path, outputs.options, job.replaces, (job.source,))
    if job.snapshots_nc is not None:
        check_series(job.snapshots_nc, bool(job.snapshot_ages), "--snapshots", job.replaces, (job.source,))
    check_output(timeline_path(job.output), job.replaces, (job.source,))
    _check_nesting_options(job, names)
    if job.write_fluxes:
        check_fluxes_folder(fluxes_folder(job.output), job.kept_ages(), job.replaces)
    check_png(chronology_png_path(job.output), job.replaces, (job.source,))
    if job.checkpoint_every < 1:
        raise InputError("--checkpoint-every must be at least 1 step.")


def input_files(job: ClimateJob) -> list[Path]:
    """Every file the run reads (the parameter values that name files included)."""
    named = (job.source, job.chronology, job.sea_level_file, job.schedule_file, job.downstream_mask,
             job.dirichlet, edge_base_table(job.edge_base_choice), job.uplift_map, job.inflow,
             job.inflow_from)
    return [Path(p) for p in named if p is not None] + parameter_files(job)


def _fingerprint(job: ClimateJob) -> str:
    """Hash of everything that decides the result (inputs' content included), to refuse a
    --resume from a checkpoint of another run."""
    fields = {opt.name: getattr(job, opt.name) for opt in job.OPTIONS if opt.name not in _NOT_FINGERPRINTED}
    files = [p for p in input_files(job) if p != job.inflow_from] + _coarse_files(job)
    return run_fingerprint(fields, files)


def _coarse_files(job: ClimateJob) -> list[Path]:
    """The nesting rasters of ``--inflow-from``, for the fingerprint."""
    if job.inflow_from is None:
        return []
    folder = coarse_run_folder(job.inflow_from)
    return sorted(folder.glob("*.tif")) if folder.is_dir() else []


def parameter_files(job: ClimateJob) -> list[Path]:
    """The files given as parameter values (rasters, the uplift table)."""
    return [Path(text) for text in job.parameter_values().values()
            if text is not None and Path(text).is_file()]


def is_table(text: str | None) -> bool:
    """Whether a parameter value names a CSV table through time rather than a number or raster."""
    return text is not None and Path(text).suffix.lower() == ".csv"


def flag(name: str) -> str:
    """The option of a parameter: ``k_f`` → ``--k-f``."""
    return f"--{name.replace('_', '-')}"


def _check_no_glacier_options(job: ClimateJob) -> None:
    """Refuse, in a run without glaciers, the options only the glacier model takes."""
    if job.ela_present is not None or job.ela_glacial is not None:
        raise InputError("--ela-present and --ela-glacial set the ELA of the glaciers; add glacial to "
                         "--process.")
    if job.iceflow is not None or job.seed is not None:
        raise InputError("--iceflow and --seed set the glaciers' ice flow; add glacial to --process.")
    for spec in GLACIER_ONLY_PARAMETERS:
        if getattr(job, spec.name) is not None:
            raise InputError(f"{flag(spec.name)} is a parameter of the glacier model (001); add glacial "
                             "to --process.")


def _check_scalable(job: ClimateJob, schedule: Schedule, base: dict[str, Any]) -> None:
    """Refuse, before any step, a schedule that cannot scale one of the run's rasters."""
    try:
        for phase in PHASES:
            schedule.apply(phase, base)
    except ValueError as exc:
        raise InputError(f"{job.schedule_file}: {exc}.") from None


def _uplift_history(job: ClimateJob, table: str | None, terrain: Terrain,
                    schedule: Schedule) -> UpliftHistory | None:
    """``--uplift TABLE.csv`` (``age_ka`` and ``U_m_per_y``, or ``factor`` times the raster of
    ``--uplift-map``) covering the whole run; None when ``--uplift`` is a number or a raster."""
    if table is None:
        if job.uplift_map is not None:
            raise InputError(f"--uplift-map needs --uplift TABLE.csv with columns age_ka,{FACTOR_COLUMN}.")
        return None
    series = read_age_table(Path(table), "uplift", (RATE_COLUMN, FACTOR_COLUMN))
    if not series.covers(np.array([job.from_ka, job.to_ka])):
        raise InputError(f"the uplift table {table} covers {series.start_ka:g}–{series.end_ka:g} ka, "
                         f"not the whole run from {job.from_ka:g} to {job.to_ka:g} ka.")
    if any(UPLIFT.name in values for values in schedule.phases.values()):
        raise InputError(f"the schedule {job.schedule_file} sets the uplift per phase and --uplift is a "
                         "table; give the uplift through time in one of them.")
    if series.name == RATE_COLUMN:
        if job.uplift_map is not None:
            raise InputError(f"--uplift-map multiplies an uplift table of {FACTOR_COLUMN}, and {table} "
                             f"holds {RATE_COLUMN}.")
        return UpliftHistory(series)
    if job.uplift_map is None:
        raise InputError(f"the uplift table {table} holds a {FACTOR_COLUMN}; give the raster it "
                         "multiplies (m/y) with --uplift-map.")
    return UpliftHistory(series, resolve(UPLIFT, str(job.uplift_map), terrain))


def _check_nesting_options(job: ClimateJob, names: list[str]) -> None:
    """Refuse, before any work, nesting options that do not go together."""
    if job.inflow is not None and job.inflow_from is not None:
        raise InputError("give the inflow either as a table (--inflow) or from a coarse run "
                         "(--inflow-from), not both.")
    if job.edge_base == COARSE and job.inflow_from is None:
        raise InputError("--edge-base coarse follows the surface of a coarse run: give it with "
                         "--inflow-from.")
    for option, given in (("--inflow-from", job.inflow_from is not None),
                          ("--write-fluxes", job.write_fluxes)):
        if given and "fluvial" not in names:
            raise InputError(f"{option} concerns the water and sediment of the fluvial process; add "
                             "fluvial to --process.")
