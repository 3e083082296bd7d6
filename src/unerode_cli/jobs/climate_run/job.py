"""A `climate-run` job: (un)erode a DEM step by step along a paleo-climate chronology
(000 §5, DESIGN §7), with boundary nodes that follow their base level (the sea for the coast,
else fixed, uplifted or from a table), snapshots at asked ages, a timeline, checkpoints and
resume.

Ages are in ka at the edges (options, files, tags) and converted to years inside. A step of
``dt`` years goes from age a to a ± dt/1000 ka; its phase and scheduled parameters are those of
its middle age, and the boundary nodes are set, before the step, to their base level at the
step's end age (``run.boundaries.BaseLevels``), e.g. h_b(t) = h_b(start) + (sea(t) − sea(start))
on the coast, so that after each step they follow it exactly.

With ``glacial`` in ``--process`` the run is glaciate's coupled glacier model (001 §3–6) instead,
forward only, with the ELA from the same chronology; ``plan_glacial`` checks such a run and gives
what the glacier job needs besides the options: the ice-free processes asked for and the sea
level through the run, the base level of their routing (one chronology, both forcings). The
command line hands that to the glaciate job (no job imports another).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.climate.chronology import YEARS_PER_KA, Series
from unerode_cli.climate.phases import PHASES, PhaseThresholds, classify
from unerode_cli.climate.schedule import DOWNSTREAM_K_D, Schedule, downstream_mask
from unerode_cli.climate.sealevel import DEFAULT_MAPPING, SeaLevelMapping, sea_level
from unerode_cli.climate.uplift import FACTOR_COLUMN, RATE_COLUMN, UpliftHistory
from unerode_cli.errors import InputError
from unerode_cli.glacier import cycle, erosion, massbalance
from unerode_cli.io.checkpoints import check_checkpoint, checkpoint_path, read_checkpoint, write_checkpoint
from unerode_cli.io.chronology_files import read_age_table, read_series
from unerode_cli.io.coarse_runs import (
    check_fluxes_folder,
    coarse_run_folder,
    fluxes_folder,
    read_coarse_run,
    write_state,
)
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.grid_rasters import load_on_grid
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.yaml_files import read_yaml_mapping
from unerode_cli.processes.fluvial import Inflow
from unerode_cli.processes.inflow import InflowHistory
from unerode_cli.processes.parameters import UPLIFT
from unerode_cli.run.boundaries import COARSE, BaseLevels, base_levels_from_options, edge_base_table
from unerode_cli.run.divergence import DivergenceGuard, max_rate
from unerode_cli.run.fingerprint import run_fingerprint
from unerode_cli.run.nesting import Nesting, nest
from unerode_cli.run.outputs import (
    AGE_TAG,
    PHASE_TAG,
    SEA_TAG,
    TIME_TAG,
    Outputs,
    check_png,
    check_raster,
    save,
)
from unerode_cli.run.parameter_maps import resolve
from unerode_cli.run.registry import (
    GLACIAL,
    REGISTRY,
    build_processes,
    given_values,
    inflow_history_for,
    parse_process_list,
    thermal_constraints,
)
from unerode_cli.run.runner import run
from unerode_cli.viz.chronology_plot import save_chronology_plot

COMMAND = "climate-run"
#: Glacier steps (y) longer than this get a note (001 §5: 10–100 y).
GLACIER_DT_NOTE = 100.0
#: What ``--process`` may list with ``glacial``: glaciate's processes of ice-free ground (001 §6).
GLACIAL_PROCESSES = (GLACIAL, "hillslope", "debris", "fluvial")
#: Parameters only the glacier model takes: its mass balance (001 Eq. 2; the ELA comes from the
#: chronology), glacial erosion (001 §6.1) and the k_f of its rivers (001 §6.3).
GLACIER_ONLY_PARAMETERS = (*(s for s in massbalance.PARAMETERS if s.name != "ela"), *erosion.PARAMETERS,
                           cycle.K_F)
#: Every parameter a run with glaciers takes: those, the ice-free processes' and the uplift.
GLACIAL_PARAMETERS = frozenset(spec.name for spec in (*GLACIER_ONLY_PARAMETERS, *cycle.PARAMETERS))


@dataclass(frozen=True)
class ClimateJob:
    """What the user asked for; ages in ka, ``dt`` in years."""

    source: Path
    output: Path
    chronology: Path
    from_ka: float
    to_ka: float
    chronology_kind: str = "d18o"
    sea_level_file: Path | None = None
    d18o_mapping: tuple[float, float] | None = None
    direction: str | None = None
    dt: float = 1000.0
    process: str = "fluvial,thermal"
    snapshots_ka: tuple[float, ...] = ()
    schedule_file: Path | None = None
    downstream_below: float | None = None
    downstream_mask: Path | None = None
    outlets: str = "all"
    dirichlet: Path | None = None
    sea_outlets: bool = True
    coast: str = "none"
    edge_base: str | None = None
    checkpoint_every: int = 10
    resume: bool = False
    max_steps: int | None = None
    allow_substeps: bool = True
    scheme: str = "limiter"
    method: str = "mfd"
    constraints: str = "slope,convexity,rate"
    dtype: str = "float32"
    cog: bool = False
    co: list[str] | None = None
    overwrite: bool = False
    preview: Path | None = None
    uplift_map: Path | None = None
    inflow: Path | None = None
    inflow_from: Path | None = None
    write_fluxes: bool = False
    ela_present: float | None = None
    ela_glacial: float | None = None
    parameter_values: dict[str, str | None] = field(default_factory=dict)

    @property
    def backward(self) -> bool:
        return self.to_ka > self.from_ka

    @property
    def edge_base_choice(self) -> str:
        """``--edge-base``, by default "coarse" for a nested run (``--inflow-from``), else "fixed"."""
        if self.edge_base is not None:
            return self.edge_base
        return COARSE if self.inflow_from is not None else "fixed"

    def kept_ages(self) -> list[float]:
        """Ages (ka) of the nesting rasters of ``--write-fluxes``: the start, the snapshots and
        the end."""
        return sorted({self.from_ka, *self.snapshots_ka, self.to_ka})


@dataclass(frozen=True)
class SeaLevelSource:
    """Sea level (m relative to present) by age as climate-run takes it (000 §5.1–5.2): from the
    chronology when it is a sea-level curve, else from ``--sea-level``, else from the δ18O
    chronology through ``mapping`` (``climate.sealevel``)."""

    sea: Series | None
    d18o: Series | None
    mapping: SeaLevelMapping

    @classmethod
    def of(cls, job: ClimateJob, chronology: Series, sea: Series | None,
           mapping: SeaLevelMapping) -> SeaLevelSource:
        if job.chronology_kind == "sea-level":
            return cls(chronology, None, mapping)
        return cls(sea, chronology if job.chronology_kind == "d18o" else None, mapping)

    @property
    def series(self) -> Series:
        """The table the sea level is read from (sea level, else δ18O)."""
        series = self.sea if self.sea is not None else self.d18o
        assert series is not None
        return series

    def at(self, ages_ka: np.ndarray) -> np.ndarray:
        """Sea level (m) at ``ages_ka`` (ka); ValueError (one sentence) outside the table."""
        return np.asarray(sea_level(ages_ka, self.sea, self.d18o, self.mapping), dtype=float)

    def since(self, from_ka: float) -> Callable[[float], float]:
        """The sea level (m) at t years after the age ``from_ka`` (ka) of a forward run."""
        return lambda time_y: float(self.at(np.asarray(from_ka - time_y / YEARS_PER_KA)))


@dataclass
class Forcing:
    """Per-step forcing: end ages (ka), middle-age phases and sea levels (m), end sea levels."""

    end_ka: np.ndarray
    mid_ka: np.ndarray
    phase: np.ndarray
    sea_mid: np.ndarray
    sea_end: np.ndarray
    sea_start: float


@dataclass
class PreparedClimateRun:
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


def timeline_path(output: Path) -> Path:
    return output.with_name(f"{output.stem}_timeline.csv")


def chronology_png_path(output: Path) -> Path:
    return output.with_name(f"{output.stem}_chronology.png")


def snapshot_path(output: Path, age_ka: float) -> Path:
    """``past.tif`` at 12 ka → ``past_12ka.tif``."""
    return output.with_name(f"{output.stem}_{age_ka:g}ka{output.suffix}")


def _steps(job: ClimateJob) -> int:
    if not (np.isfinite(job.dt) and job.dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {job.dt:g}.")
    if job.from_ka == job.to_ka:
        raise InputError("--from and --to are the same age: nothing to run.")
    wanted = "backward" if job.backward else "forward"
    if job.direction is not None and job.direction != wanted:
        raise InputError(f"--direction {job.direction} does not match --from {job.from_ka:g} "
                         f"--to {job.to_ka:g} ka, which runs {wanted} in time.")
    count = abs(job.to_ka - job.from_ka) * 1000.0 / job.dt
    if count < 0.5:
        raise InputError(f"--dt {job.dt:g} years is longer than the span {job.from_ka:g}–{job.to_ka:g} ka "
                         "of the run.")
    if abs(count - round(count)) > 1e-9 * max(1.0, count):
        raise InputError(f"the span {job.from_ka:g}–{job.to_ka:g} ka is not a whole number of "
                         f"--dt {job.dt:g} year steps.")
    return round(count)


def _forcing(job: ClimateJob, steps: int, sea: SeaLevelSource) -> Forcing:
    sign = 1.0 if job.backward else -1.0
    k = np.arange(1, steps + 1, dtype=np.float64)
    end = job.from_ka + sign * k * job.dt / 1000.0
    mid = end - sign * 0.5 * job.dt / 1000.0
    try:
        sea_mid, sea_end = sea.at(mid), sea.at(end)
        sea_start = float(sea.at(np.array([job.from_ka]))[0])
        # phases need the trend around each age: classify on a 1 ka grid, read at the middles
        lo, hi = min(job.from_ka, job.to_ka), max(job.from_ka, job.to_ka)
        source = sea.series
        grid = np.arange(max(source.start_ka, lo - 30.0), min(source.end_ka, hi + 30.0) + 1e-9, 1.0)
        phases_on_grid = classify(grid, sea.at(grid), PhaseThresholds())
    except ValueError as exc:
        raise InputError(f"{exc}") from None
    # nearest grid age (1 ka apart), the younger one on ties
    pick = np.clip(np.ceil(mid - grid[0] - 0.5).astype(np.int64), 0, grid.size - 1)
    return Forcing(end, mid, np.asarray(phases_on_grid)[pick], sea_mid, sea_end, sea_start)


def _fingerprint(job: ClimateJob) -> str:
    """Hash of everything that decides the result (inputs' content included), to refuse a
    --resume from a checkpoint of another run."""
    fields = asdict(job)
    for key in ("resume", "max_steps", "overwrite", "preview", "checkpoint_every"):
        fields.pop(key)
    return run_fingerprint(fields, (job.source, job.chronology, job.sea_level_file, job.schedule_file,
                                    job.downstream_mask, job.dirichlet, edge_base_table(job.edge_base_choice),
                                    job.uplift_map, job.inflow, *_parameter_files(job), *_coarse_files(job)))


def plan(job: ClimateJob, on_note: Callable[[str], None] | None = None) -> PreparedClimateRun:
    """Check everything before the first step: options, outputs, inputs, chronology range;
    ``on_note`` hears what was changed in the tables as read (rows left out or sorted)."""
    names = parse_process_list(job.process, job.backward)
    _check_no_glacier_options(job)
    steps = _steps(job)
    outputs = Outputs.from_cli(job.output, job.dtype, job.cog, job.co,
                               job.overwrite or job.resume, job.preview)
    outputs.check(job.source)
    step_ends = {round(job.from_ka + (1 if job.backward else -1) * k * job.dt / 1000.0, 9)
                 for k in range(1, steps + 1)}
    for age in job.snapshots_ka:
        if round(age, 9) not in step_ends:
            raise InputError(f"snapshot age {age:g} ka is not the end of a step of the run "
                             f"({job.from_ka:g} → {job.to_ka:g} ka by {job.dt:g} years).")
    _check_checkpoint(job)
    replace = job.overwrite or job.resume
    for path in [snapshot_path(job.output, a) for a in job.snapshots_ka]:
        check_raster(path, outputs.options, replace, (job.source,))
    check_output(timeline_path(job.output), replace, (job.source,))
    _check_nesting_options(job, names)
    if job.write_fluxes:
        check_fluxes_folder(fluxes_folder(job.output), job.kept_ages(), replace)
    check_png(chronology_png_path(job.output), replace, (job.source,))
    if job.checkpoint_every < 1:
        raise InputError("--checkpoint-every must be at least 1 step.")
    terrain = read_terrain(job.source)
    terrain.check_valid(job.source)
    outputs.check_source(terrain, job.source)
    chronology, sea = _read_sea_level(job, on_note)
    forcing = _forcing(job, steps, sea)
    try:
        schedule = Schedule.from_mapping(read_yaml_mapping(
            job.schedule_file, "the schedule file", "a mapping of phases to parameters",
        )) if job.schedule_file else Schedule()
    except ValueError as exc:
        raise InputError(f"{job.schedule_file}: {exc}") from None
    given = given_values(None, job.parameter_values, names)
    table = given.pop(UPLIFT.name) if _is_table(given.get(UPLIFT.name)) else None
    base = {}
    for name in names:
        for spec in REGISTRY[name].parameters:
            text = given.get(spec.name)
            base[spec.name] = resolve(spec, spec.default if text is None else text, terrain)
    _check_scalable(job, schedule, base)
    uplift = _uplift_history(job, table, terrain, schedule)
    base_levels = base_levels_from_options(
        terrain, job.outlets, job.dirichlet, job.coast, job.edge_base_choice,
        forcing.sea_start if job.sea_outlets else None, (job.from_ka, job.to_ka))
    downstream = None
    if job.downstream_mask is not None or job.downstream_below is not None:
        mask = (load_on_grid(job.downstream_mask, terrain, "downstream mask") != 0
                if job.downstream_mask else None)
        downstream = downstream_mask(terrain.elevation, job.downstream_below, mask)
    start_outlets = base_levels.boundaries(forcing.sea_start if job.sea_outlets else None)
    inflow = inflow_history_for(job.inflow, names, terrain, start_outlets)
    nesting = None
    if job.inflow_from is not None:
        nodes = base_levels.edge if base_levels.edge_base == COARSE else np.zeros(terrain.shape, bool)
        nesting = nest(read_coarse_run(job.inflow_from), terrain,
                       start_outlets.outlets(terrain.elevation, terrain), nodes,
                       (job.from_ka, job.to_ka))
        inflow = nesting.inflow
        if base_levels.edge_base == COARSE:
            base_levels = dataclasses.replace(base_levels, node_levels=nesting.levels)
    elif inflow is not None and not (inflow.covers(job.from_ka) and inflow.covers(job.to_ka)):
        raise InputError(f"the inflow table {job.inflow} covers {inflow.span_ka[0]:g}–"
                         f"{inflow.span_ka[1]:g} ka, not the whole run from {job.from_ka:g} to "
                         f"{job.to_ka:g} ka.")
    return PreparedClimateRun(job, terrain, names, base, schedule, forcing, base_levels, downstream,
                              steps, outputs, chronology, _fingerprint(job), uplift, inflow, nesting)


def is_glacial(process: str) -> bool:
    """Whether ``--process`` lists the glacier model (``glacial``): then ``plan_glacial``."""
    return GLACIAL in (name.strip().lower() for name in process.split(","))


@dataclass(frozen=True)
class GlacialRun:
    """What a climate-run with glaciers adds to its options (``plan_glacial``): the processes of
    ice-free ground on (001 §6.2–6.4), the sea level (m) at t years after ``--from`` (None with
    ``--no-sea-outlets``), the parameter values for the glacier model (name → text), and the
    parameters its history adds (the sea level's source)."""

    hillslope: bool
    debris: bool
    fluvial: bool
    sea_level: Callable[[float], float] | None
    parameter_values: dict[str, str | None]
    context: dict[str, Any]


#: climate-run's options that mean nothing to the glacier model: option → (``ClimateJob`` field,
#: why), refused when given (``_check_glacial_options``).
_NOT_GLACIAL = {
    "--params": ("schedule_file", "the glacier model has no schedule of parameters by climate phase"),
    "--downstream-below": ("downstream_below", "its rivers erode and do not deposit"),
    "--downstream-mask": ("downstream_mask", "its rivers erode and do not deposit"),
    "--uplift-map": ("uplift_map", "its uplift is a number or a raster, not a table through time"),
    "--dirichlet": ("dirichlet", "its base level is the map's edges and the sea"),
    "--coast": ("coast", "its base level is the map's edges and the sea"),
    "--edge-base": ("edge_base", "its base level is the map's edges and the sea"),
    "--outlets": ("outlets", "its base level is all the map's edges and the sea"),
    "--inflow": ("inflow", "rivers entering the map feed the fluvial model of 000 only"),
    "--inflow-from": ("inflow_from", "rivers entering the map feed the fluvial model of 000 only"),
    "--write-fluxes": ("write_fluxes", "the nesting rasters come from the fluvial model of 000 only"),
    "--scheme": ("scheme", "it sets the slope of backward steps, and glaciers run forward only"),
    "--thermal-constraints": ("constraints", "thermal erosion does not run with glaciers"),
    "--method": ("method", "the rivers of ice-free ground follow steepest descent (D8)"),
    "--snapshots": ("snapshots_ka", "the glacier run writes the bed at --to and one timeline row per step"),
}


def plan_glacial(job: ClimateJob, on_note: Callable[[str], None] | None = None) -> GlacialRun:
    """Check a climate-run with glaciers (``--process glacial[,hillslope,debris,fluvial]``)
    before any work, and read the sea level along it; the glacier job checks the rest (the ELA's
    chronology, outputs, parameter values)."""
    names = _glacial_names(job.process)
    if job.backward:
        raise InputError("glaciers run forward in time only, so --to must be younger than --from: ice "
                         "flow and glacial erosion cannot be reversed, and the ice that once covered "
                         "the DEM is not known to start from.")
    if job.ela_present is None or job.ela_glacial is None:
        raise InputError("--process glacial needs --ela-present and --ela-glacial (today's ELA and the "
                         "ELA at the last glacial maximum, m) to turn the chronology into the ELA.")
    _check_glacial_options(job)
    if job.dt > GLACIER_DT_NOTE and on_note is not None:
        on_note(f"note: --dt {job.dt:g} y is long for glaciers: 001 §5 steps them 10–100 y (its Fig. 11: "
                "the ice volume within 1 % at 10–20 y, about 10 % at 100 y).")
    values = _glacial_values(job)
    _steps(job)
    _, sea = _read_sea_level(job, on_note)
    try:
        sea.at(np.array([job.from_ka, job.to_ka]))  # the table covers the run
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    mapping = None if sea.d18o is None else asdict(sea.mapping)
    context = {"process": job.process, "chronology_kind": job.chronology_kind,
               "sea_level_file": job.sea_level_file, "d18o_to_sea": mapping, "sea_outlets": job.sea_outlets}
    return GlacialRun("hillslope" in names, "debris" in names, "fluvial" in names,
                      sea.since(job.from_ka) if job.sea_outlets else None, values, context)


def _glacial_names(process: str) -> list[str]:
    """The names of ``--process`` with ``glacial``, each one of ``GLACIAL_PROCESSES``, once."""
    names = [name.strip().lower() for name in process.split(",") if name.strip()]
    for name in names:
        if name.startswith("thermal"):
            raise InputError(f"{name} cannot run with glacial: the glacier model couples only hillslope, "
                             "debris and fluvial (001 §6), and its debris flow takes the place of thermal "
                             "erosion on slopes steeper than the critical angle.")
        if name not in GLACIAL_PROCESSES:
            raise InputError(f"unknown process '{name}'; with glacial choose among "
                             f"{', '.join(GLACIAL_PROCESSES[1:])}.")
    if len(set(names)) != len(names):
        raise InputError(f"--process names a process twice: {process}.")
    return names


def _check_glacial_options(job: ClimateJob) -> None:
    """Refuse the options of ``_NOT_GLACIAL`` that differ from their default: given, or for the
    few with a default value (e.g. ``--outlets all``), given another value."""
    defaults = {f.name: f.default for f in dataclasses.fields(ClimateJob)}
    for option, (name, why) in _NOT_GLACIAL.items():
        if getattr(job, name) != defaults[name]:
            raise InputError(f"{option} does not apply with --process glacial ({why}); drop it.")


def _glacial_values(job: ClimateJob) -> dict[str, str | None]:
    """The given parameter values, each one of the glacier model's (``GLACIAL_PARAMETERS``); the
    uplift a number or a raster."""
    given = {name: text for name, text in job.parameter_values.items() if text is not None}
    for name in given:
        if name not in GLACIAL_PARAMETERS:
            raise InputError(f"{_flag(name)} does not apply with --process glacial, whose rivers erode by "
                             "k_f·A^m·S^n (--k-f, 001 §6.3) and whose other parameters are the mass "
                             "balance, glacial erosion, hillslope, debris-flow and uplift ones; drop it.")
    if _is_table(given.get(UPLIFT.name)):
        raise InputError("--uplift with --process glacial is a number (m/y) or a raster, not a table "
                         "through time.")
    return given


def _check_no_glacier_options(job: ClimateJob) -> None:
    """Refuse, in a run without glaciers, the options only the glacier model takes."""
    if job.ela_present is not None or job.ela_glacial is not None:
        raise InputError("--ela-present and --ela-glacial set the ELA of the glaciers; add glacial to "
                         "--process.")
    for spec in GLACIER_ONLY_PARAMETERS:
        if job.parameter_values.get(spec.name) is not None:
            raise InputError(f"{_flag(spec.name)} is a parameter of the glacier model (001); add glacial "
                             "to --process.")


def _flag(name: str) -> str:
    """The option of a parameter: ``k_f`` → ``--k-f``."""
    return f"--{name.replace('_', '-')}"


def _read_sea_level(job: ClimateJob, on_note: Callable[[str], None] | None) -> tuple[Series, SeaLevelSource]:
    """The chronology, and the sea level by age from it, ``--sea-level`` and ``--d18o-to-sea``."""
    chronology = read_series(job.chronology, job.chronology_kind, on_note=on_note)
    sea = read_series(job.sea_level_file, "sea-level", on_note=on_note) if job.sea_level_file else None
    mapping = SeaLevelMapping(*job.d18o_mapping) if job.d18o_mapping else DEFAULT_MAPPING
    return chronology, SeaLevelSource.of(job, chronology, sea, mapping)


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


def _coarse_files(job: ClimateJob) -> list[Path]:
    """The nesting rasters of ``--inflow-from``, for the fingerprint."""
    if job.inflow_from is None:
        return []
    folder = coarse_run_folder(job.inflow_from)
    return sorted(folder.glob("*.tif")) if folder.is_dir() else []


def _parameter_files(job: ClimateJob) -> list[Path]:
    """The files given as parameter values (rasters, the uplift table)."""
    return [Path(text) for text in job.parameter_values.values()
            if text is not None and Path(text).is_file()]


def _is_table(text: str | None) -> bool:
    """Whether a parameter value names a CSV table through time rather than a number or raster."""
    return text is not None and Path(text).suffix.lower() == ".csv"


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


def _check_checkpoint(job: ClimateJob) -> None:
    """A checkpoint left by an unfinished run is continued with --resume or replaced with
    --overwrite, never silently."""
    check_checkpoint(job.output, job.resume, job.overwrite, (job.source,))


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
    job = prepared.job
    bounds = prepared.base_levels.boundaries(sea_end if job.sea_outlets else None)
    options = {"scheme": job.scheme, "method": job.method,
               "constraints": thermal_constraints(job.constraints), "inflow": inflow}
    return build_processes(prepared.names, prepared.terrain, bounds, values, options)


def run_climate(prepared: PreparedClimateRun, on_step=None, on_note=None) -> str:
    """Run (or resume) the climate run, write every output, return a one-line summary."""
    job, terrain, forcing = prepared.job, prepared.terrain, prepared.forcing
    start_time = time.perf_counter()
    h, first, rows = _start_state(prepared, on_note)
    signed_dt = (-1.0 if job.backward else 1.0) * job.dt
    last = prepared.steps if job.max_steps is None else min(prepared.steps, first + job.max_steps)
    snapshots = {round(a, 9) for a in job.snapshots_ka}
    noted: set[str] = set()
    guard = DivergenceGuard(terrain.elevation, hint="lower --dt or the rates (K, k_th), or drop a "
                            "process that runs away backward")

    def note_once(message: str) -> None:
        """Pass a sub-stepping note on at its first climate step only (one per process)."""
        key = message.split(" (", 1)[0]
        if on_note is not None and key not in noted:
            noted.add(key)
            on_note(f"{message[:-1]}, first at {forcing.end_ka[k]:g} ka; no further note.")

    for k in range(first, last):
        values, scheduled = step_values(prepared, k)
        guard.uplift_rate = max(guard.uplift_rate, max_rate(values.get(UPLIFT.name, 0.0)))  # U may vary
        sea_end = float(forcing.sea_end[k])
        prepared.base_levels.set_levels(h, terrain.elevation, sea_end - forcing.sea_start,
                                        float(forcing.end_ka[k]), values.get("uplift", 0.0), signed_dt)
        before = h.copy()
        inflow = None if prepared.inflow is None else prepared.inflow.at(float(forcing.mid_ka[k]))
        processes = _processes(prepared, values, sea_end, inflow)
        h, report = run(h, processes, signed_dt, 1, job.allow_substeps, None, note_once)
        guard.check(h, (k + 1) * signed_dt, f"at {forcing.end_ka[k]:g} ka")
        change = np.abs(h - before)[~terrain.nodata_mask]
        rows.append({"age_ka": float(forcing.end_ka[k]), "phase": str(forcing.phase[k]),
                     "sea_level_m": sea_end, **scheduled,
                     "eroded_m3": sum(b.eroded for b in report.budgets.values()),
                     "deposited_m3": sum(b.deposited for b in report.budgets.values()),
                     **(_inflow_columns(report, inflow) if inflow is not None else {}),
                     "mean_abs_dh_m": float(change.mean()), "max_abs_dh_m": float(change.max())})
        if round(float(forcing.end_ka[k]), 9) in snapshots:
            _save_state(prepared, h, k, snapshot_path(job.output, float(forcing.end_ka[k])))
        if job.write_fluxes:
            _write_fluxes(prepared, processes, k, before, h, snapshots)
        if (k + 1) % job.checkpoint_every == 0 or k + 1 == last:
            _checkpoint(prepared, h, k + 1, rows)
        if on_step is not None:
            on_step(f"{forcing.end_ka[k]:.6g} ka, {forcing.phase[k]}, sea {sea_end:+.1f} m")
    if last < prepared.steps:
        return (f"{COMMAND}: stopped after step {last} of {prepared.steps} "
                f"({forcing.end_ka[last - 1]:g} ka); run again with --resume to continue.")
    _save_state(prepared, h, prepared.steps - 1, job.output, final=True, rows=rows,
                wall=time.perf_counter() - start_time)
    _write_timeline(timeline_path(job.output), rows)
    with atomic_path(chronology_png_path(job.output)) as tmp:
        save_chronology_plot(tmp, forcing.end_ka, forcing.phase, forcing.sea_end,
                             prepared.chronology.age_ka, prepared.chronology.value,
                             f"{prepared.chronology.name} ({prepared.chronology.unit})",
                             job.snapshots_ka, title=job.output.name)
    checkpoint_path(job.output).unlink(missing_ok=True)
    return (f"{COMMAND}: {prepared.steps} steps of {job.dt:g} y from {job.from_ka:g} to "
            f"{job.to_ka:g} ka; wrote {job.output}, {timeline_path(job.output).name}, "
            f"{chronology_png_path(job.output).name} and {len(job.snapshots_ka)} snapshot(s)"
            + (f", and the nesting rasters in {fluxes_folder(job.output).name}/" if job.write_fluxes else "")
            + f"; {prepared.base_levels.summary()}"
            + (f"; {prepared.nesting.summary()}" if prepared.nesting is not None else ""))


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


def _start_state(prepared: PreparedClimateRun, on_note) -> tuple[np.ndarray, int, list[dict]]:
    job = prepared.job
    path = checkpoint_path(job.output)
    h = np.array(prepared.terrain.elevation, dtype=np.float64, copy=True)
    if not job.resume:
        return h, 0, []
    if not path.exists():
        if on_note is not None:
            on_note(f"note: no checkpoint {path.name} to resume from; starting from the beginning.")
        return h, 0, []
    saved = read_checkpoint(path)
    if str(saved["fingerprint"]) != prepared.fingerprint:
        raise InputError(f"the checkpoint {path} belongs to a run with other inputs or "
                         "options; run without --resume (or with the same options).")
    state = np.array(saved["elevation"], dtype=np.float64)
    done = int(saved["step"])
    rows = json.loads(str(saved["timeline"]))
    if on_note is not None:
        on_note(f"note: resuming after step {done} of {prepared.steps}.")
    return state, done, rows


def _checkpoint(prepared: PreparedClimateRun, h: np.ndarray, done: int, rows: list[dict]) -> None:
    path = checkpoint_path(prepared.job.output)
    write_checkpoint(path, elevation=h, step=done, timeline=json.dumps(rows),
                     fingerprint=prepared.fingerprint)


def _save_state(prepared: PreparedClimateRun, h: np.ndarray, k: int, path: Path,
                final: bool = False, rows: list[dict] | None = None, wall: float = 0.0) -> None:
    job, forcing = prepared.job, prepared.forcing
    state = prepared.terrain.with_elevation(h)
    age = float(forcing.end_ka[k])
    state.tags.update({AGE_TAG: repr(age), SEA_TAG: repr(float(forcing.sea_end[k])),
                       PHASE_TAG: str(forcing.phase[k]),
                       TIME_TAG: repr((age - job.from_ka) * -1000.0)})
    outputs = prepared.outputs if final else Outputs(path, prepared.outputs.options, True)
    statistics = {"age_ka": age, "sea_level_m": float(forcing.sea_end[k]),
                  "phase": str(forcing.phase[k]), "boundaries": prepared.base_levels.counts()}
    if final and rows is not None:
        statistics.update({"steps": prepared.steps, "wall_time_s": wall,
                           "eroded_m3": float(sum(r["eroded_m3"] for r in rows)),
                           "deposited_m3": float(sum(r["deposited_m3"] for r in rows)),
                           **({"inflow_m3": float(sum(r["inflow_m3"] for r in rows))}
                              if prepared.inflow is not None else {}),
                           "snapshots": [str(snapshot_path(job.output, a))
                                         for a in job.snapshots_ka]})
    save(state, outputs, COMMAND, _provenance(job), statistics)


def _provenance(job: ClimateJob) -> dict[str, Any]:
    fields = asdict(job)
    fields.pop("parameter_values")
    return {**fields, **{k: v for k, v in job.parameter_values.items() if v is not None}}


def _write_timeline(path: Path, rows: list[dict[str, Any]]) -> None:
    columns: list[str] = []
    for row in rows:
        columns += [c for c in row if c not in columns]
    write_table(path, columns, rows)
