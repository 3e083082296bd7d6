"""A `glaciate` job (001): plan (check everything, read inputs) then run the coupled glacier model
(``glacier.coupled``) or solve the velocity of a given geometry once (diagnostic mode), and write.

Inputs: the DEM is the bedrock (m). ``--ela`` is a number (m), a raster on the DEM's grid, or a
CSV time table with the columns ``time`` (years since the start of the run) and ``ela`` (m),
interpolated linearly and held beyond its ends. ``--sliding-C`` is a number, ``inf`` (frozen
bed) or a raster. ``--ice-thickness`` (m, a raster on the DEM's grid) is the initial ice of a
run, or the geometry of a diagnostic solve.

Outputs: the eroded bed (a DEM like the input; its JSON sidecar holds the ice-volume series
and the solver statistics), the final ice thickness (``--ice``), surface velocity (``--velocity``,
two bands vx, vy in m/y, x east, y along the rows, i.e. south) and basal speed (``--sliding``,
m/y) of the final geometry, and ice-thickness snapshots ``ICE_001.tif``... (``--ice`` or
``OUT_ice``) every ``--snapshot-every`` years.

Checkpoints: every ``--checkpoint-every`` steps the run's whole state (bed, ice, the last
velocities, the step cap, the totals, the timeline so far and the state of the ice-free
processes) goes to ``.OUT.checkpoint.npz`` beside OUT; ``--resume`` continues from it with the
steps an uninterrupted run would take, and ``--max-steps`` stops an invocation after so many
steps (checkpointed). A finished run removes its checkpoint; a run that diverges removes it with
everything else it wrote.

A job may carry a sea level through time (``GlacierJob.sea_level``, e.g. climate-run's along the
chronology that drives the ELA): its cells become base level of the ice-free processes
(``glacier.cycle``) and the timeline gains a ``sea_level_m`` column.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.climate import ela as ela_model
from unerode_cli.climate.chronology import YEARS_PER_KA, Series
from unerode_cli.errors import InputError, RunFailure
from unerode_cli.glacier import blatter, coupled, cycle, erosion, lakes, massbalance
from unerode_cli.hydro.outlets import outlet_mask
from unerode_cli.io.checkpoints import check_checkpoint, checkpoint_path, read_checkpoint, write_checkpoint
from unerode_cli.io.csv_tables import table_number, table_rows, write_table
from unerode_cli.io.ela_files import read_ela_proxy
from unerode_cli.io.gdal_io import WriteOptions
from unerode_cli.io.grid_rasters import read_on_grid, write_bands
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.provenance import history_entry, write_sidecar
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.divergence import DivergenceGuard, max_rate
from unerode_cli.run.fingerprint import run_fingerprint
from unerode_cli.run.outputs import (
    AGE_TAG,
    SEA_TAG,
    TIME_TAG,
    Outputs,
    check_png,
    check_previewable,
    check_raster,
    save,
    snapshot_path,
)
from unerode_cli.run.parameter_maps import resolve
from unerode_cli.viz.glacial_chronology_plot import save_glacial_chronology_plot

COMMAND = "glaciate"
#: Mass-balance and erosion parameters given as ``--NAME`` options (number or raster).
PARAMETERS = (*(s for s in massbalance.PARAMETERS if s.name != "ela"), *erosion.PARAMETERS)
#: The processes of ice-free ground and the uplift (``glacier.cycle``), also ``--NAME`` options.
SURFACE_PARAMETERS = cycle.PARAMETERS
ELA_SPEC = next(s for s in massbalance.PARAMETERS if s.name == "ela")
SLIDING_SPEC = next(s for s in blatter.PARAMETERS if s.name == "sliding_c")
#: The diagnostic solve: blatter.solve's own convergence threshold, and a generous iteration cap.
DIAGNOSTIC_RTOL = 1e-5
DIAGNOSTIC_MAX_ITER = 20000
#: Ice thicker than this (m) under the multi-scale transport at a CFL number above
#: ``THICK_ICE_CFL`` gets a note: one-cell grooves in the surface of ice this thick grew into a
#: divergence at 001's c = 0.1 (001 Fig. 6's ice sheet of up to 1.3 km at 250 m cells; the
#: Grindelwald cycle under 2–2.5 km at 92 m), and 0.05 kept both down (``coupled._multiscale_cfl``).
THICK_ICE_M = 1000.0
THICK_ICE_CFL = 0.05


@dataclass(frozen=True)
class GlacierJob:
    """What the user asked for (lengths in m, times in years, the background slope in degrees).

    ``sea_level``: None, or the sea level (m, relative to present) at a time (y since the start):
    a base level of the ice-free processes (``glacier.cycle``). ``command`` names the run in its
    history and summary, ``context`` adds to the parameters of its history (e.g. climate-run's
    sea-level source).
    """

    source: Path
    output: Path | None
    ela: str | None = None
    duration: float | None = None
    dt: float = 10.0
    iceflow: str = "blatter"
    layers: int = 10
    sliding_c: str = repr(blatter.DEFAULT_SLIDING_C)
    sliding_sigma: float = 1.5
    rate_factor: float | None = None
    boundary: str = "open"
    background_slope: float = 0.0
    transport: str = "multiscale"
    transport_cfl: float = coupled.MULTISCALE_CFL
    allow_substeps: bool = True
    erosion: bool = True
    ice_thickness: Path | None = None
    ice: Path | None = None
    velocity: Path | None = None
    sliding: Path | None = None
    snapshot_every: float | None = None
    hillslope: bool = True
    debris: bool = True
    fluvial: bool = True
    shield_thickness: float = cycle.SHIELD_THICKNESS
    drainage_every: int = cycle.DRAINAGE_EVERY
    lakes: Path | None = None
    timeline: Path | None = None
    ela_chronology: Path | None = None
    ela_kind: str = "d18o"
    ela_present: float | None = None
    ela_glacial: float | None = None
    ela_lapse_rate: float | None = None
    from_ka: float | None = None
    to_ka: float = 0.0
    diagnostic: bool = False
    band: int | None = None
    channel: str | None = None
    dtype: str = "float32"
    cog: bool = False
    co: list[str] | None = None
    overwrite: bool = False
    preview: Path | None = None
    checkpoint_every: int = 100
    resume: bool = False
    max_steps: int | None = None
    parameter_values: dict[str, str | None] = field(default_factory=dict)
    sea_level: Callable[[float], float] | None = None
    command: str = COMMAND
    context: dict[str, Any] = field(default_factory=dict)

    @property
    def replaces(self) -> bool:
        """Whether existing outputs may be replaced: --overwrite, or --resume (the outputs of the
        run being continued)."""
        return self.overwrite or self.resume


@dataclass
class PreparedGlacierJob:
    """A checked job: inputs read, parameters built, every output path cleared."""

    job: GlacierJob
    terrain: Terrain
    params: coupled.CoupledParams
    thickness: np.ndarray
    ela: coupled.Ela | None
    chronology: Series | None
    surface: cycle.SurfaceParams
    times: np.ndarray
    snapshot_times: list[float]
    write: WriteOptions
    parameters: dict[str, Any]
    fingerprint: str = ""

    @property
    def steps(self) -> int:
        return len(self.times)


def plan(job: GlacierJob) -> PreparedGlacierJob:
    """Check the whole job before any work: options, outputs, inputs, parameters."""
    _check_options(job)
    write = Outputs.from_cli(job.source, job.dtype, job.cog, job.co, job.replaces, None).options
    snapshot_times = _snapshot_times(job)
    _check_outputs(job, snapshot_times, write)
    _check_checkpoint(job)
    terrain = read_terrain(job.source, band=job.band, channel=job.channel)
    terrain.check_valid(job.source)
    if job.preview is not None:
        check_previewable(terrain, job.source)
    thickness = read_thickness(job.ice_thickness, terrain)
    ela = None if job.ela is None else read_ela(job.ela, terrain)
    chronology = None
    if job.ela_chronology is not None:
        chronology = read_ela_proxy(job.ela_chronology, job.ela_kind)
        ela = chronology_ela(job, chronology)
    given = {k: v for k, v in job.parameter_values.items() if v is not None}
    values = {spec.name: resolve(spec, given.get(spec.name, spec.default), terrain) for spec in PARAMETERS}
    surface_values = {spec.name: resolve(spec, given.get(spec.name, spec.default), terrain)
                      for spec in SURFACE_PARAMETERS}
    flow_params = {"sliding_c": sliding_coefficient(job.sliding_c, terrain), "sigma": job.sliding_sigma,
                   "n_layers": job.layers}
    if job.rate_factor is not None:
        flow_params["glen_a"] = job.rate_factor
    try:
        params = coupled.CoupledParams(
            flow=blatter.FlowParams(**flow_params), iceflow=job.iceflow, transport=job.transport,
            multiscale_cfl=job.transport_cfl, allow_substeps=job.allow_substeps, boundary=job.boundary,
            background_slope=math.radians(job.background_slope), erosion=job.erosion,
            held_bed=outlet_mask(terrain.grid, "all" if job.boundary == "open" else "none"), **values)
        params.validate(terrain.shape)
        surface = cycle.surface_params(surface_values, job.hillslope, job.debris, job.fluvial,
                                       job.shield_thickness, job.drainage_every)
        surface.validate(terrain.grid)
        times = np.array([]) if job.diagnostic else coupled.step_times(_duration(job), job.dt,
                                                                             snapshot_times)
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    parameters = _provenance(job, params, given)
    return PreparedGlacierJob(job, terrain, params, thickness, ela, chronology, surface, times,
                              snapshot_times, write, parameters, _fingerprint(job))


def _fingerprint(job: GlacierJob) -> str:
    """The run's fingerprint (``run.fingerprint``): its options but those of the checkpoints,
    the overwriting and the preview, and the contents of its input files."""
    fields = asdict(replace(job, sea_level=None))
    for key in ("resume", "max_steps", "overwrite", "preview", "checkpoint_every"):
        fields.pop(key)
    values = [v for v in job.parameter_values.values() if v is not None]
    files = [job.source, job.ice_thickness, job.ela_chronology, job.sliding_c, job.ela, *values]
    return run_fingerprint(fields, [f for f in files if f is not None and Path(str(f)).is_file()])


def _check_checkpoint(job: GlacierJob) -> None:
    """A checkpoint left by an unfinished run is continued with --resume or replaced with
    --overwrite, never silently."""
    if job.diagnostic or job.output is None:
        return
    if job.checkpoint_every < 1:
        raise InputError(f"--checkpoint-every must be at least 1 step, got {job.checkpoint_every}.")
    if job.max_steps is not None and job.max_steps < 1:
        raise InputError(f"--max-steps must be at least 1 step, got {job.max_steps}.")
    check_checkpoint(job.output, job.resume, job.overwrite, (job.source,))


def _check_options(job: GlacierJob) -> None:
    if not (math.isfinite(job.shield_thickness) and job.shield_thickness >= 0):
        raise InputError(f"--shield-thickness must be a thickness ≥ 0 m, got {job.shield_thickness:g}.")
    if job.drainage_every < 1:
        raise InputError(f"--drainage-every must be a whole number ≥ 1, got {job.drainage_every}.")
    if job.layers < 1:
        raise InputError(f"--layers must be a whole number ≥ 1, got {job.layers}.")
    if not (math.isfinite(job.sliding_sigma) and job.sliding_sigma >= 1.0):
        raise InputError(f"--sliding-sigma must be ≥ 1, got {job.sliding_sigma:g}.")
    if job.rate_factor is not None and not (math.isfinite(job.rate_factor) and job.rate_factor > 0):
        raise InputError(f"--rate-factor must be a positive number (Pa⁻³/y), got {job.rate_factor:g}.")
    if not (math.isfinite(job.background_slope) and abs(job.background_slope) < 90.0):
        raise InputError("--background-slope must be an angle in (−90, 90) degrees, "
                         f"got {job.background_slope:g}.")
    if job.diagnostic:
        if job.ice_thickness is None:
            raise InputError("--diagnostic needs --ice-thickness (the geometry to solve).")
        if job.output is None and job.velocity is None and job.sliding is None:
            raise InputError("--diagnostic writes --velocity, --sliding or OUT; give at least one.")
        return
    if job.output is None:
        raise InputError("OUT (the eroded bed) is required unless --diagnostic is given.")
    if job.ela_chronology is not None:
        _check_chronology_options(job)
    elif job.ela is None:
        raise InputError("--ela (a number in m, a raster, or a CSV time table) or --ela-chronology "
                         "is required.")
    elif job.duration is None or not (math.isfinite(job.duration) and job.duration > 0):
        raise InputError("--duration must be given as a positive number of years.")
    if not (math.isfinite(job.dt) and job.dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {job.dt:g}.")
    if job.snapshot_every is not None and not (math.isfinite(job.snapshot_every) and job.snapshot_every > 0):
        raise InputError(f"--snapshot-every must be a positive number of years, got {job.snapshot_every:g}.")


def _check_chronology_options(job: GlacierJob) -> None:
    if job.ela is not None or job.duration is not None:
        raise InputError("--ela-chronology sets the ELA and the duration: drop --ela and --duration.")
    if job.from_ka is None:
        raise InputError("--ela-chronology needs --from (the age in ka where the run starts).")
    if job.ela_present is None:
        raise InputError("--ela-chronology needs --ela-present (today's ELA in m).")
    if (job.ela_glacial is None) == (job.ela_lapse_rate is None):
        raise InputError("--ela-chronology needs one of --ela-glacial (the ELA at the last glacial maximum, "
                         "m) or --ela-lapse-rate (m/K, with a temperature chronology).")
    if job.ela_lapse_rate is not None and job.ela_kind != "temperature":
        raise InputError("--ela-lapse-rate needs --ela-kind temperature.")
    if job.ela_kind not in ela_model.ELA_KINDS:
        raise InputError(f"--ela-kind must be one of {', '.join(ela_model.ELA_KINDS)}, got {job.ela_kind!r}.")


def chronology_ela(job: GlacierJob, series: Series) -> coupled.ElaTable:
    """The ELA through the run from the proxy ``series`` of ``--ela-chronology`` (``climate.ela``:
    linear in the proxy between today and the last glacial maximum, or a lapse rate on a
    temperature), as a table of years since ``--from``."""
    assert job.from_ka is not None and job.ela_present is not None
    try:
        if job.ela_lapse_rate is not None:
            values = ela_model.ela_from_temperature(series, job.ela_lapse_rate, job.ela_present,
                                                    series.age_ka)
        else:
            assert job.ela_glacial is not None
            values = ela_model.ela_from_proxy(series, job.ela_kind, job.ela_present, job.ela_glacial,
                                              series.age_ka)
        times, ela = ela_model.ela_table(series.age_ka, values, job.from_ka, job.to_ka,
                                         str(job.ela_chronology))
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    return coupled.ElaTable(times, ela)


def _duration(job: GlacierJob) -> float | None:
    """Simulated years: ``--duration``, or from ``--from`` to ``--to`` along a chronology."""
    if job.from_ka is not None and job.ela_chronology is not None:
        return (job.from_ka - job.to_ka) * YEARS_PER_KA
    return job.duration


def _snapshot_times(job: GlacierJob) -> list[float]:
    duration = _duration(job)
    if job.diagnostic or job.snapshot_every is None or duration is None:
        return []
    count = math.floor(duration / job.snapshot_every * (1.0 + 1e-12))
    return [k * job.snapshot_every for k in range(1, count + 1)]


def chronology_png_path(output: Path) -> Path:
    """The chronology plot of a run along ``--ela-chronology``: OUT_chronology.png."""
    return output.with_name(f"{output.stem}_chronology.png")


def snapshot_base(job: GlacierJob) -> Path:
    """Ice snapshots are numbered after ``--ice``, else after ``OUT_ice``."""
    assert job.output is not None
    return job.ice or job.output.with_name(f"{job.output.stem}_ice{job.output.suffix}")


def _check_outputs(job: GlacierJob, snapshot_times: list[float], write: WriteOptions) -> None:
    inputs = tuple(p for p in (job.source, job.ice_thickness) if p is not None)
    rasters = [p for p in (job.output, job.ice, job.velocity, job.sliding, job.lakes) if p is not None]
    if snapshot_times:
        rasters += [snapshot_path(snapshot_base(job), k) for k in range(1, len(snapshot_times) + 1)]
    pngs = [p for p in (job.preview,) if p is not None]
    if job.ela_chronology is not None:
        assert job.output is not None
        pngs.append(chronology_png_path(job.output))
    paths = rasters + pngs + [p for p in (job.timeline,) if p is not None]
    if len(set(map(Path.resolve, paths))) != len(paths):
        raise InputError("two outputs have the same path.")
    if job.velocity is not None and job.velocity.suffix.lower() not in (".tif", ".tiff"):
        raise InputError("the velocity output has two bands and must be a GeoTIFF (.tif), "
                         f"got {job.velocity.name}.")
    for path in rasters:
        check_raster(path, write, job.replaces, inputs)
    for png in pngs:
        check_png(png, job.replaces, inputs)
    if job.timeline is not None:
        check_output(job.timeline, job.replaces, inputs)


def read_thickness(path: Path | None, terrain: Terrain) -> np.ndarray:
    """Ice thickness (m) on the DEM's grid: finite and ≥ 0 inside the domain, 0 outside; zeros
    when no raster is given."""
    if path is None:
        return np.zeros(terrain.shape)
    layer = read_on_grid(path, terrain, "ice thickness").elevation
    valid = terrain.grid.valid
    inside = layer[valid]
    if not np.isfinite(inside).all():
        raise InputError(f"the ice-thickness raster {path} has nodata or NaN cells inside the DEM's domain.")
    if (inside < 0).any():
        raise InputError(f"the ice-thickness raster {path} has negative thicknesses "
                         f"(min {inside.min():g} m).")
    return np.where(valid, layer, 0.0)


def read_ela(text: str, terrain: Terrain) -> coupled.Ela:
    """``--ela``: a number (m), a CSV time table (``time``, ``ela`` columns) or a raster."""
    if Path(text).suffix.lower() == ".csv":
        return read_ela_table(Path(text))
    return resolve(ELA_SPEC, text, terrain)


def read_ela_table(path: Path) -> coupled.ElaTable:
    """The ELA table at ``path``: years since the start of the run, ELA in m (module docstring)."""
    times: list[float] = []
    values: list[float] = []
    for line, row in table_rows(path, "ELA", ("time", "ela"), ("time", "ela")):
        t, e = table_number(row, "time", path, line), table_number(row, "ela", path, line)
        if times and t <= times[-1]:
            raise InputError(f"{path}, line {line}: the times of an ELA table must increase.")
        times.append(t)
        values.append(e)
    if not times:
        raise InputError(f"the ELA table {path} has no row.")
    return coupled.ElaTable(np.array(times), np.array(values))


def sliding_coefficient(text: str, terrain: Terrain) -> float | np.ndarray:
    """``--sliding-C``: ``inf`` (frozen bed), a number ≥ 0 or a raster (Pa·(y/m)^(σ−1))."""
    if text.strip().lower() in ("inf", "+inf", "infinity"):
        return math.inf
    return resolve(SLIDING_SPEC, text, terrain)


def _provenance(job: GlacierJob, params: coupled.CoupledParams, given: dict[str, str]) -> dict[str, Any]:
    return {"input": job.source, "ela": job.ela, "duration_years": job.duration, "dt_years": job.dt,
            "iceflow": job.iceflow, "layers": job.layers, "sliding_c": job.sliding_c,
            "sliding_sigma": job.sliding_sigma, "rate_factor": params.flow.glen_a, "boundary": job.boundary,
            "background_slope_degrees": job.background_slope, "transport": job.transport,
            "transport_cfl": job.transport_cfl, "allow_substeps": job.allow_substeps, "erosion": job.erosion,
            "ice_thickness": job.ice_thickness,
            "diagnostic": job.diagnostic, "hillslope": job.hillslope, "debris": job.debris,
            "fluvial": job.fluvial, "shield_thickness_m": job.shield_thickness,
            "drainage_every": job.drainage_every, "ela_chronology": job.ela_chronology,
            "ela_kind": job.ela_kind, "ela_present": job.ela_present, "ela_glacial": job.ela_glacial,
            "ela_lapse_rate": job.ela_lapse_rate, "from_ka": job.from_ka, "to_ka": job.to_ka,
            "flow_rtol": DIAGNOSTIC_RTOL if job.diagnostic else params.flow_rtol,
            **{spec.name: given.get(spec.name, spec.default) for spec in (*PARAMETERS, *SURFACE_PARAMETERS)},
            **job.context}


# --- running --------------------------------------------------------------------------------------

def run_job(prepared: PreparedGlacierJob, on_step=None, on_note=None) -> str:
    """Run the coupled model, write the outputs and return a one-line summary.

    ``on_step(years, info)`` is called after every step (ramp steps included) with the simulated
    years done and a line on the step: ice volume, fastest ice, the velocity solver's iterations
    and relative residual; ``on_note(text)`` with notes for the user (e.g. no ice can form).

    Divergence (``DivergenceGuard``, as erode and climate-run): after every step the bed, and the
    ice surface b + H, must be finite and within 5 × the DEM's relief (+ 100 m) of the starting
    DEM — the surface also may rise by p_max (m/y) times the years run, as snow piles up. A run
    that leaves that bound stops at that step (RunFailure, exit 1) before anything is written;
    snapshots written before are removed by the caller's output handling."""
    job, terrain = prepared.job, prepared.terrain
    grid = terrain.grid
    start = time.perf_counter()
    state = coupled.GlacierState(coupled.fill_outside(terrain.elevation, grid.valid), prepared.thickness)
    snapshots: list[Path] = []
    timeline: list[dict[str, Any]] = []
    note = ""
    outlets = outlet_mask(grid)  # the map's edges and the borders of nodata
    ice_free = _ice_free_erosion(prepared, outlets)
    never = coupled.never_glaciated(state.bed, state.thickness, grid, prepared.ela)
    if never:
        note = _no_ice_note(terrain, prepared.ela, ice_free is not None)
        if on_note is not None:
            on_note(note)
    if never and ice_free is None:
        end = coupled.GlacierState(state.bed, state.thickness, float(prepared.times[-1]))
        result = coupled.RunResult(end, [0.0, end.time], [0.0, 0.0], steps=0)
        for k, t in enumerate(prepared.snapshot_times, start=1):
            path = snapshot_path(snapshot_base(job), k)
            _save_layer(prepared, state.thickness, path, "m", {"time_years": t}, t)
            snapshots.append(path)
        if on_step is not None:
            on_step(end.time, "no ice")
    else:
        resumed = _resume(prepared, ice_free, on_note)
        if resumed is not None:
            state, timeline, snapshots = resumed.result.state, resumed.timeline, resumed.snapshots
            start -= resumed.wall
        first = 0 if resumed is None else resumed.result.steps
        stop_at = None if job.max_steps is None else first + job.max_steps
        hint = ("lower --dt or, under thick ice, --transport-cfl (0.05 kept 001 Fig. 6's ice sheet "
                "stable), or raise --sliding-C if the ice slides at km/y")
        bed_guard = DivergenceGuard(terrain.elevation, hint=hint)
        surface_guard = DivergenceGuard(terrain.elevation + prepared.thickness,
                                        uplift_rate=max_rate(prepared.params.p_max), hint=hint)

        thick_note = _ThickIceNote(prepared.params, on_note)

        def check(new: coupled.GlacierState, report: coupled.StepReport, k: int) -> None:
            where = f"in step {k} (t = {new.time:g} y)"
            bed_guard.check(new.bed, new.time, where)
            surface_guard.check(new.bed + new.thickness, new.time, where)
            thick_note.check(new)
            if job.timeline is not None:
                timeline.append(_timeline_row(prepared, new, report, ice_free,
                                              outlets if ice_free is None else ice_free.base_level))
            if on_step is not None:
                on_step(new.time, _step_info(report))
            if any(math.isclose(new.time, t, rel_tol=1e-12) for t in prepared.snapshot_times):
                path = snapshot_path(snapshot_base(job), len(snapshots) + 1)
                _save_layer(prepared, new.thickness, path, "m", {"time_years": new.time}, new.time)
                snapshots.append(path)
            if k % job.checkpoint_every == 0 or k == stop_at:
                _checkpoint(prepared, progress, timeline, snapshots, ice_free, time.perf_counter() - start)
            if k == stop_at and new.time < prepared.times[-1]:
                raise _Stopped(k, new.time)

        progress = coupled.RunResult(state, [state.time], [coupled.ice_volume(state.thickness, grid)]) \
            if resumed is None else resumed.result
        times = prepared.times[prepared.times > state.time + 1e-9 * max(job.dt, 1.0)]
        try:
            result = coupled.run(state, grid, prepared.params, prepared.ela, times, None, check,
                                 ice_free, progress)
        except _Stopped as stop:
            return (f"{job.command}: stopped after step {stop.step} (t = {stop.time:g} y of "
                    f"{prepared.times[-1]:g}); run again with --resume to continue.")
        except coupled.UnstableStep as exc:
            raise InputError(
                f"--dt {exc.dt:g} y is above the stable explicit ice-transport step {exc.stable:.3g} y "
                f"(reached at t = {exc.time:g} y); lower --dt or drop --no-substep.") from None
        except coupled.Diverged as exc:
            raise RunFailure(f"{exc}; lower --dt or --transport-cfl, or use --transport explicit") from None
        except coupled.TooManySubsteps as exc:
            raise RunFailure(
                f"{exc}; use the multi-scale transport (the default) or a shorter --dt") from None
    final = result.state
    stats = _statistics(result, terrain, time.perf_counter() - start, snapshots, note)
    # the job's "other" adds its set-up to the loop's own (coupled.run), so the parts add up to the wall
    parts = dict(result.seconds)
    parts["other"] = max(0.0, stats["wall_time_s"] - sum(v for k, v in parts.items() if k != "other"))
    stats["wall_time_by_part_s"] = parts
    if ice_free is not None:
        stats["ice_free_removed_m3"] = dict(ice_free.removed)
        stats["ice_free_wall_time_s"] = dict(ice_free.seconds)
    flow = _final_flow(prepared, final) if (job.velocity or job.sliding) else None
    if flow is not None:
        stats["final_flow"] = _flow_statistics(flow)
    bed = terrain.with_elevation(final.bed)
    bed.tags.update(_time_tags(prepared, final.time))
    assert job.output is not None
    save(bed, Outputs(job.output, prepared.write, job.replaces, job.preview), job.command,
         prepared.parameters, stats)
    if job.ice is not None:
        _save_layer(prepared, final.thickness, job.ice, "m", stats, final.time)
    if flow is not None:
        _write_flow(prepared, flow, stats)
    if job.lakes is not None:
        depth = lakes.lake_depth(final.bed, final.thickness, grid, outlets)
        stats["lakes"] = asdict(lakes.lake_stats(depth, grid))
        _save_layer(prepared, depth, job.lakes, "m", stats, final.time)
    if job.timeline is not None:
        write_table(job.timeline, list(TIMELINE_COLUMNS) + ([SEA_COLUMN] if job.sea_level else []), timeline)
    if prepared.chronology is not None:
        _write_chronology_plot(prepared, result)
    summary = (f"{job.command}: {result.steps} steps to t = {final.time:g} y"
               f"{_forcing_summary(prepared, result)}; ice volume {result.volumes[-1] / 1e9:.4g} km³; "
               f"removed {result.eroded:.4g} m³ of bedrock; wrote {job.output}")
    if result.unconverged:
        summary += (f"\nnote: {result.unconverged} of {result.steps} velocity solves stopped at "
                    f"{prepared.params.flow_max_iter} iterations (largest residual "
                    f"{result.max_residual:.2g}, "
                    f"asked {prepared.params.flow_rtol:g}); their velocities are approximate")
    checkpoint_path(job.output).unlink(missing_ok=True)
    return summary


class _Stopped(Exception):
    """--max-steps reached (after a checkpoint): ``step`` steps done, at ``time`` (y)."""

    def __init__(self, step: int, time_y: float) -> None:
        super().__init__(f"stopped after step {step}")
        self.step, self.time = step, time_y


@dataclass
class _Resumed:
    """A run continued from its checkpoint: its state and totals (``result``), timeline rows,
    snapshots written and wall-clock seconds so far."""

    result: coupled.RunResult
    timeline: list[dict[str, Any]]
    snapshots: list[Path]
    wall: float


_RESULT_TOTALS = ("steps", "substeps", "resolves", "evaluations", "unconverged", "max_residual", "eroded",
                  "retries", "cap")


def _checkpoint(prepared: PreparedGlacierJob, result: coupled.RunResult, timeline: list[dict[str, Any]],
                snapshots: list[Path], ice_free: cycle.IceFreeErosion | None, wall: float) -> None:
    """Write the run's whole state to its checkpoint (module docstring)."""
    job, state = prepared.job, result.state
    assert job.output is not None
    lattice = state.lattice if state.lattice is not None else (np.zeros(0), np.zeros(0))
    totals = {name: getattr(result, name) for name in _RESULT_TOTALS}
    free = ice_free.saved() if ice_free is not None else None
    arrays = {}
    if free is not None:
        arrays = {"free_base_level": free["base_level"], "free_fixed": free["fixed"],
                  "free_routed": free["routed"]}
        free = {"steps": free["steps"], "removed": free["removed"], "seconds": free["seconds"]}
    write_checkpoint(checkpoint_path(job.output), fingerprint=prepared.fingerprint, bed=state.bed,
                     thickness=state.thickness, time=state.time, lattice_u=lattice[0], lattice_v=lattice[1],
                     series_times=np.array(result.times), series_volumes=np.array(result.volumes),
                     totals=json.dumps({**totals, "seconds": result.seconds, "wall": wall}),
                     timeline=json.dumps(timeline), snapshots=json.dumps([str(p) for p in snapshots]),
                     ice_free=json.dumps(free), **arrays)


class _ThickIceNote:
    """Tells the user once when the ice grows thicker than ``THICK_ICE_M`` under a multi-scale CFL
    number above ``THICK_ICE_CFL``."""

    def __init__(self, params: coupled.CoupledParams, on_note) -> None:
        self.on_note = on_note
        self.cfl = params.multiscale_cfl
        self.pending = (on_note is not None and params.transport == "multiscale"
                        and params.multiscale_cfl > THICK_ICE_CFL)

    def check(self, state: coupled.GlacierState) -> None:
        if not self.pending:
            return
        thickest = float(state.thickness.max())
        if thickest > THICK_ICE_M:
            self.pending = False
            self.on_note(f"note: the ice is {thickest:.0f} m thick at t = {state.time:g} y; under ice this "
                         f"thick --transport-cfl {self.cfl:g} can grow one-cell grooves in its surface "
                         f"until the run diverges (an ice sheet, a glacial maximum): {THICK_ICE_CFL:g} "
                         "keeps them down.")


def _resume(prepared: PreparedGlacierJob, ice_free: cycle.IceFreeErosion | None, on_note) -> _Resumed | None:
    """The run to continue with --resume (None: start from the beginning)."""
    job = prepared.job
    assert job.output is not None
    path = checkpoint_path(job.output)
    if not job.resume:
        return None
    if not path.exists():
        if on_note is not None:
            on_note(f"note: no checkpoint {path.name} to resume from; starting from the beginning.")
        return None
    saved = read_checkpoint(path)
    if str(saved["fingerprint"]) != prepared.fingerprint:
        raise InputError(f"the checkpoint {path} belongs to a run with other inputs or options; run "
                         "without --resume (or with the same options).")
    lattice = (saved["lattice_u"], saved["lattice_v"]) if saved["lattice_u"].size else None
    state = coupled.GlacierState(saved["bed"], saved["thickness"], float(saved["time"]), lattice)
    totals = json.loads(str(saved["totals"]))
    result = coupled.RunResult(state, list(map(float, saved["series_times"])),
                               list(map(float, saved["series_volumes"])),
                               seconds={**dict.fromkeys(coupled.WALL_TIME_PARTS, 0.0), **totals["seconds"]},
                               **{name: totals[name] for name in _RESULT_TOTALS})
    free = json.loads(str(saved["ice_free"]))
    if (free is None) != (ice_free is None):
        raise InputError(f"the checkpoint {path} does not match this run's processes of ice-free ground.")
    if ice_free is not None:
        ice_free.restore({**free, "base_level": saved["free_base_level"], "fixed": saved["free_fixed"],
                          "routed": saved["free_routed"]})
    if on_note is not None:
        on_note(f"note: resuming after step {result.steps} (t = {state.time:g} y of {prepared.times[-1]:g}).")
    return _Resumed(result, json.loads(str(saved["timeline"])),
                    [Path(p) for p in json.loads(str(saved["snapshots"]))], float(totals["wall"]))


def _write_chronology_plot(prepared: PreparedGlacierJob, result: coupled.RunResult) -> None:
    """OUT_chronology.png: the proxy, the ELA at the start of each step and the ice volume."""
    job, series = prepared.job, prepared.chronology
    assert series is not None and job.output is not None and job.from_ka is not None
    times = np.asarray(result.times)
    ela = [float(np.mean(coupled.ela_at(prepared.ela, t))) for t in times]
    with atomic_path(chronology_png_path(job.output)) as tmp:
        save_glacial_chronology_plot(tmp, series.age_ka, series.value, f"{series.name} ({series.unit})",
                                     job.from_ka - times / YEARS_PER_KA, np.array(ela),
                                     np.array(result.volumes), title=job.output.name)


def _age(prepared: PreparedGlacierJob, time_y: float) -> float | None:
    """The age (ka) at ``time_y`` (y since the start) of a run along a chronology, else None."""
    job = prepared.job
    if job.from_ka is None or job.ela_chronology is None:
        return None
    return job.from_ka - time_y / YEARS_PER_KA


def _time_tags(prepared: PreparedGlacierJob, time_y: float) -> dict[str, str]:
    """Tags of the bed at ``time_y`` (y): the time, and along a chronology the age (ka) and the
    sea level (m) when the job has one (as climate-run tags its outputs)."""
    tags = {TIME_TAG: repr(time_y)}
    age = _age(prepared, time_y)
    if age is not None:
        tags[AGE_TAG] = repr(age)
    if prepared.job.sea_level is not None:
        tags[SEA_TAG] = repr(prepared.job.sea_level(time_y))
    return tags


def _forcing_summary(prepared: PreparedGlacierJob, result: coupled.RunResult) -> str:
    """The forcings of a run along a chronology in words: the ELA range (m) over the steps and,
    with a sea level, its range (m); empty for other runs."""
    age = _age(prepared, 0.0)
    if age is None:
        return ""
    times = np.asarray(result.times)
    ela = [float(np.mean(coupled.ela_at(prepared.ela, t))) for t in times[:-1]]
    text = f" from {age:g} to {_age(prepared, times[-1]):g} ka (ELA {min(ela):.0f}–{max(ela):.0f} m"
    if prepared.job.sea_level is not None:
        sea = [prepared.job.sea_level(t) for t in times]
        text += f", sea level {min(sea):+.1f} to {max(sea):+.1f} m"
    return text + ")"


#: Columns of ``--timeline``: one row per step taken (ramp steps included), at its end.
TIMELINE_COLUMNS = ("time_y", "age_ka", "ela_m", "ice_volume_m3", "ice_area_m2", "glacial_eroded_m3",
                    "ice_free_removed_m3", "lake_area_m2")
#: The column a job with a sea level adds: the sea level (m) at the step's end.
SEA_COLUMN = "sea_level_m"


def _timeline_row(prepared: PreparedGlacierJob, state: coupled.GlacierState, report: coupled.StepReport,
                  ice_free: cycle.IceFreeErosion | None, outlets: np.ndarray) -> dict[str, Any]:
    """One row of ``--timeline`` (``TIMELINE_COLUMNS``): the ELA of the step (mean of a map), the
    ice, the volume eroded by the glaciers in the step and carried off by the other processes
    since the start, the area of the lakes (which drain to ``outlets``); with a sea level, the
    sea level at the step's end (``SEA_COLUMN``)."""
    job, grid = prepared.job, prepared.terrain.grid
    ela = np.asarray(coupled.ela_at(prepared.ela, state.time - report.dt), dtype=np.float64)
    sea = {} if job.sea_level is None else {SEA_COLUMN: job.sea_level(state.time)}
    return {"time_y": state.time,
            "age_ka": _age(prepared, state.time),
            "ela_m": float(ela[grid.valid].mean() if ela.ndim else ela),
            "ice_volume_m3": report.volume,
            "ice_area_m2": float(np.count_nonzero(state.thickness[grid.valid] > lakes.ICE_FREE_BELOW))
            * grid.cell_area,
            "glacial_eroded_m3": report.eroded,
            "ice_free_removed_m3": sum(ice_free.removed.values()) if ice_free is not None else 0.0,
            "lake_area_m2": lakes.lake_stats(lakes.lake_depth(state.bed, state.thickness, grid, outlets),
                                             grid).area_m2, **sea}


def _ice_free_erosion(prepared: PreparedGlacierJob, outlets: np.ndarray) -> cycle.IceFreeErosion | None:
    """The processes of ice-free ground after each glacier step (``glacier.cycle``) towards
    ``outlets`` and the job's sea; None when every one is off and there is no uplift."""
    surface = prepared.surface
    if surface.hillslope is surface.debris is surface.fluvial is None and not np.any(surface.uplift):
        return None
    return cycle.IceFreeErosion(surface, prepared.terrain.grid, outlets, prepared.job.sea_level)


def _step_info(report: coupled.StepReport) -> str:
    """One step in words: the ice volume, the fastest column, and the velocity solve."""
    flow = report.flow
    text = f"step {report.dt:g} y, ice {report.volume / 1e9:.4g} km³, max speed {flow.max_speed():.4g} m/y"
    if flow.lattice is not None:
        text += (f", Blatter–Pattyn {flow.iterations} iterations, residual {flow.residual:.3g}"
                 + ("" if flow.converged else " (not converged)"))
    return text


def run_diagnostic(prepared: PreparedGlacierJob) -> str:
    """Solve the velocity of the given geometry once and write the asked outputs."""
    job, terrain = prepared.job, prepared.terrain
    start = time.perf_counter()
    bed = coupled.fill_outside(terrain.elevation, terrain.grid.valid)
    flow = coupled.flow_field(bed, prepared.thickness, terrain.grid, prepared.params, rtol=DIAGNOSTIC_RTOL,
                              max_iter=DIAGNOSTIC_MAX_ITER, energy_rtol=0.0)
    stats = {"flow": _flow_statistics(flow), "wall_time_s": time.perf_counter() - start}
    if job.output is not None:
        save(terrain.with_elevation(terrain.elevation), Outputs(job.output, prepared.write,
                                                                job.overwrite, job.preview),
             job.command, prepared.parameters, stats)
    _write_flow(prepared, flow, stats)
    state = "converged" if flow.converged else "NOT converged"
    written = ", ".join(str(p) for p in (job.velocity, job.sliding, job.output) if p is not None)
    return (f"{job.command} --diagnostic: velocity solved with {job.iceflow} ({state}, residual "
            f"{flow.residual:.3g}, {flow.iterations} iterations); max surface speed "
            f"{float(np.max(np.hypot(*flow.surface))):.4g} m/y; wrote {written}")


def _final_flow(prepared: PreparedGlacierJob, state: coupled.GlacierState) -> coupled.FlowField:
    """Velocities of the final geometry (warm-started, with the run's re-solve policy)."""
    return coupled.flow_field(state.bed, state.thickness, prepared.terrain.grid, prepared.params,
                              warm=state.lattice)


def _write_flow(prepared: PreparedGlacierJob, flow: coupled.FlowField, stats: dict[str, Any]) -> None:
    job, terrain = prepared.job, prepared.terrain
    if job.velocity is not None:
        entry = history_entry(job.command, prepared.parameters)
        write_bands(np.stack(flow.surface), terrain, job.velocity, prepared.write,
                    ["surface velocity vx, east (m/y)", "surface velocity vy, along rows = south (m/y)"],
                    {"UNIT": "m/y", "UNERODE_QUANTITY": "ice surface velocity"})
        write_sidecar(job.velocity, entry, stats)
    if job.sliding is not None:
        _save_layer(prepared, np.hypot(*flow.basal), job.sliding, "m/y", stats)


def _save_layer(prepared: PreparedGlacierJob, values: np.ndarray, path: Path, unit: str,
                stats: dict[str, Any], time_years: float | None = None) -> None:
    """Write a side raster (ice thickness, basal speed) on the DEM's grid, with sidecar."""
    layer = prepared.terrain.with_elevation(values)
    layer.tags["UNIT"] = unit
    if time_years is not None:
        layer.tags[TIME_TAG] = repr(time_years)
    save(layer, Outputs(path, prepared.write, prepared.job.replaces), prepared.job.command,
         prepared.parameters, stats, elevation_preview=False)


def _no_ice_note(terrain: Terrain, ela: coupled.Ela, ice_free: bool) -> str:
    peak = float(np.nanmax(terrain.elevation))
    lowest = float(np.min(ela.values if isinstance(ela, coupled.ElaTable) else np.asarray(ela)))
    outcome = "only the processes of ice-free ground change the bed" if ice_free else "the bed is unchanged"
    return (f"note: the ELA (lowest {lowest:g} m) is above every peak of the DEM (highest {peak:g} m): "
            f"no ice forms and {outcome}.")


def _flow_statistics(flow: coupled.FlowField) -> dict[str, Any]:
    return {"iterations": flow.iterations, "evaluations": flow.evaluations, "residual": flow.residual,
            "converged": flow.converged, "energy_pa_m3_per_y": flow.energy,
            "max_surface_speed_m_per_y": float(np.max(np.hypot(*flow.surface))),
            "max_sliding_speed_m_per_y": float(np.max(np.hypot(*flow.basal)))}


def _statistics(result: coupled.RunResult, terrain: Terrain, wall: float, snapshots: list[Path],
                note: str) -> dict[str, Any]:
    valid = terrain.grid.valid
    lowering = (terrain.elevation - result.state.bed)[valid]
    stats: dict[str, Any] = {
        "steps": result.steps,
        "elapsed_years": result.state.time,
        "ice_volume_series": {"time_years": result.times, "ice_volume_m3": result.volumes},
        "final_ice_volume_m3": result.volumes[-1],
        "eroded_volume_m3": result.eroded,
        "max_erosion_m": float(lowering.max()) if lowering.size else 0.0,
        "transport_substeps": result.substeps,
        "rejected_steps": result.retries,
        "velocity_resolves": result.resolves,
        "energy_evaluations": result.evaluations,
        "unconverged_solves": result.unconverged,
        "max_flow_residual": result.max_residual,
        "wall_time_s": wall,
        "snapshots": [str(p) for p in snapshots],
    }
    if note:
        stats["note"] = note
    return stats
