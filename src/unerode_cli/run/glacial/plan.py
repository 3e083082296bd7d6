"""The plan of a glacier run: every option, input and output checked and every input read before
the first step (:func:`plan_glacier`); no computation.

Inputs: the DEM is the bedrock (m). ``--ela`` is a number (m), a raster on the DEM's grid, or a
CSV time table (``io.ela_files.read_ela_table``). ``--ela-chronology`` makes the ELA a table
through the run instead, from a proxy (``climate.ela``). ``--sliding-C`` is a number, ``inf``
(frozen bed) or a raster. ``--ice-thickness`` (m, a raster on the DEM's grid) is the initial ice
of a run, or the geometry of a diagnostic solve.

A run may carry a sea level through time (``sea_level``: m relative to present at a time in
years since the start, e.g. climate-run's along the chronology that drives the ELA): its cells
become base level of the ice-free processes (``glacier.cycle``). ``command`` names the run in
its history and summary, ``context`` adds to the parameters of its history.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.climate import ela as ela_model
from unerode_cli.climate.chronology import YEARS_PER_KA, Series
from unerode_cli.errors import InputError
from unerode_cli.glacier import blatter, cnn_iceflow, coupled, cycle
from unerode_cli.hydro.outlets import outlet_mask
from unerode_cli.io.checkpoints import check_checkpoint
from unerode_cli.io.ela_files import read_ela_proxy, read_ela_table
from unerode_cli.io.gdal_io import WriteOptions
from unerode_cli.io.grid_rasters import read_on_grid
from unerode_cli.io.netcdf_files import check_series
from unerode_cli.io.paths import OutputPlan, check_output
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.common_options import input_georef
from unerode_cli.run.declare import provenance
from unerode_cli.run.fingerprint import run_fingerprint
from unerode_cli.run.glacial.options import (
    ELA_SPEC,
    MODEL_PARAMETERS,
    OPTIONS,
    SLIDING_SPEC,
    SURFACE_PARAMETERS,
    GlacierRun,
)
from unerode_cli.run.outputs import Outputs, check_png, check_previewable, check_raster, snapshot_path
from unerode_cli.run.parameter_maps import resolve
from unerode_cli.run.terrain_sanity import check_metres

#: The diagnostic solve: blatter.solve's own convergence threshold, and a generous iteration cap.
DIAGNOSTIC_RTOL = 1e-5
DIAGNOSTIC_MAX_ITER = 20000
#: Options that do not change a run's result: left out of its fingerprint.
_NOT_FINGERPRINTED = ("resume", "max_steps", "overwrite", "preview", "checkpoint_every")


@dataclass
class PreparedGlacierRun:
    """A checked run: inputs read, parameters built, every output path cleared. ``times``: the
    end times (y) of the steps asked (``coupled.step_times``; empty for a diagnostic solve);
    ``parameters``: what the outputs' histories record."""

    run: GlacierRun
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
    fingerprint: str
    command: str
    sea_level: Callable[[float], float] | None = None
    context: dict[str, Any] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        return len(self.times)


def plan_glacier(run: GlacierRun, outputs: OutputPlan, sea_level: Callable[[float], float] | None = None,
                 command: str | None = None, context: dict[str, Any] | None = None) -> PreparedGlacierRun:
    """Check the whole run before any work: options, outputs, checkpoint, inputs, parameters."""
    _check_options(run)
    for path in input_files(run):
        outputs.read(path)
    write = Outputs.from_cli(run.source, run.dtype, run.cog, run.co, run.replaces, None).options
    snapshot_times = _snapshot_times(run)
    _check_outputs(run, snapshot_times, write)
    if not run.diagnostic:
        check_checkpoint(run.output, run.resume, run.overwrite, (run.source,))
    terrain = read_terrain(run.source, band=run.band, channel=run.channel, georef=input_georef(run))
    terrain.check_valid(run.source)
    check_metres(terrain, run.source, run.force)
    if run.preview is not None:
        check_previewable(terrain, run.source)
    thickness = read_thickness(run.ice_thickness, terrain)
    ela = None if run.ela is None else read_ela(run.ela, terrain)
    chronology = None
    if run.ela_chronology is not None:
        chronology = read_ela_proxy(run.ela_chronology, run.ela_kind)
        ela = chronology_ela(run, chronology)
    given = run.given_parameters
    values = {spec.name: resolve(spec, given.get(spec.name, spec.default), terrain)
              for spec in MODEL_PARAMETERS}
    surface_values = {spec.name: resolve(spec, given.get(spec.name, spec.default), terrain)
                      for spec in SURFACE_PARAMETERS}
    flow_params = {"sliding_c": sliding_coefficient(run.sliding_c, terrain), "sigma": run.sliding_sigma,
                   "n_layers": run.layers}
    if run.rate_factor is not None:
        flow_params["glen_a"] = run.rate_factor
    try:
        params = coupled.CoupledParams(
            flow=blatter.FlowParams(**flow_params), iceflow=run.iceflow, transport=run.transport,
            multiscale_cfl=run.transport_cfl, flow_rtol=run.flow_rtol, allow_substeps=not run.no_substep,
            boundary=run.boundary,
            background_slope=math.radians(run.background_slope), erosion=run.erosion,
            edge_cells=outlet_mask(terrain.grid, "all" if run.boundary == "open" else "none"),
            cnn=cnn_iceflow.CnnIceflow(seed=run.seed) if run.iceflow == "cnn" else None, **values)
        params.validate(terrain.shape)
        surface = cycle.surface_params(surface_values, not run.no_hillslope, not run.no_debris,
                                       not run.no_fluvial, run.shield_thickness, run.drainage_every)
        surface.validate(terrain.grid)
        times = np.array([]) if run.diagnostic else coupled.step_times(duration(run), run.dt, snapshot_times)
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    command = command or run.COMMAND
    context = dict(context or {})
    return PreparedGlacierRun(run, terrain, params, thickness, ela, chronology, surface, times,
                              snapshot_times, write, _provenance(run, params, context),
                              _fingerprint(run, command, context), command, sea_level, context)


def input_files(run: GlacierRun) -> list[Path]:
    """Every file the run reads: the DEM, the initial ice, the chronology, and the ELA, sliding
    coefficient and parameter values that name files."""
    named = [path for path in (run.source, run.ice_thickness, run.ela_chronology) if path is not None]
    texts = [text for text in (run.ela, run.sliding_c, *run.given_parameters.values()) if text is not None]
    return named + [Path(text) for text in texts if Path(text).is_file()]


def _provenance(run: GlacierRun, params: coupled.CoupledParams, context: dict[str, Any]) -> dict[str, Any]:
    """The history's parameters: the recorded options, what the plan derived from them (the
    rate factor A used, the switches of the ice-free processes, the solver's tolerance), every
    parameter's value (given or default) and the ``context`` of the caller."""
    given = run.given_parameters
    specs = (*MODEL_PARAMETERS, *SURFACE_PARAMETERS)
    return {**provenance(run), "rate_factor": params.flow.glen_a, "allow_substeps": not run.no_substep,
            "hillslope": not run.no_hillslope, "debris": not run.no_debris, "fluvial": not run.no_fluvial,
            "flow_rtol": DIAGNOSTIC_RTOL if run.diagnostic else params.flow_rtol,
            **{spec.name: given.get(spec.name, spec.default) for spec in specs},
            **context}


def _fingerprint(run: GlacierRun, command: str, context: dict[str, Any]) -> str:
    """The run's fingerprint (``run.fingerprint``): its options but those of the checkpoints,
    the overwriting and the preview, its command and context, and the contents of its input
    files."""
    fields = {opt.name: getattr(run, opt.name) for opt in OPTIONS if opt.name not in _NOT_FINGERPRINTED}
    return run_fingerprint({**fields, "command": command, "context": context},
                           [p for p in input_files(run) if p.is_file()])


def _check_options(run: GlacierRun) -> None:
    """Refuse options that do not go together, or values out of range (a run built without the
    command line's checks, e.g. by the Python API)."""
    if not (math.isfinite(run.shield_thickness) and run.shield_thickness >= 0):
        raise InputError(f"--shield-thickness must be a thickness ≥ 0 m, got {run.shield_thickness:g}.")
    if run.drainage_every < 1:
        raise InputError(f"--drainage-every must be a whole number ≥ 1, got {run.drainage_every}.")
    if run.layers < 1:
        raise InputError(f"--layers must be a whole number ≥ 1, got {run.layers}.")
    if not (math.isfinite(run.sliding_sigma) and run.sliding_sigma >= 1.0):
        raise InputError(f"--sliding-sigma must be ≥ 1, got {run.sliding_sigma:g}.")
    if run.rate_factor is not None and not (math.isfinite(run.rate_factor) and run.rate_factor > 0):
        raise InputError(f"--rate-factor must be a positive number (Pa⁻³/y), got {run.rate_factor:g}.")
    if not (math.isfinite(run.background_slope) and abs(run.background_slope) < 90.0):
        raise InputError("--background-slope must be an angle in (−90, 90) degrees, "
                         f"got {run.background_slope:g}.")
    if run.diagnostic:
        if run.ice_thickness is None:
            raise InputError("--diagnostic needs --ice-thickness (the geometry to solve).")
        if run.output is None and run.velocity is None and run.sliding is None:
            raise InputError("--diagnostic writes --velocity, --sliding or OUT; give at least one.")
        return
    if run.output is None:
        raise InputError("OUT (the eroded bed) is required unless --diagnostic is given.")
    if run.ela_chronology is not None:
        _check_chronology_options(run)
    elif run.ela is None:
        raise InputError("--ela (a number in m, a raster, or a CSV time table) or --ela-chronology "
                         "is required.")
    elif run.duration is None or not (math.isfinite(run.duration) and run.duration > 0):
        raise InputError("--duration must be given as a positive number of years.")
    if not (math.isfinite(run.dt) and run.dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {run.dt:g}.")
    if run.snapshot_every is not None and not (math.isfinite(run.snapshot_every) and run.snapshot_every > 0):
        raise InputError(f"--snapshot-every must be a positive number of years, got {run.snapshot_every:g}.")
    if run.snapshot_every is not None and run.duration is not None and run.snapshot_every > run.duration:
        raise InputError(f"--snapshot-every {run.snapshot_every:g} years is outside the run, which lasts "
                         f"{run.duration:g} years (--duration): no snapshot would be written; give a "
                         "shorter interval.")
    if run.checkpoint_every < 1:
        raise InputError(f"--checkpoint-every must be at least 1 step, got {run.checkpoint_every}.")
    if run.max_steps is not None and run.max_steps < 1:
        raise InputError(f"--max-steps must be at least 1 step, got {run.max_steps}.")


def _check_chronology_options(run: GlacierRun) -> None:
    if run.ela is not None or run.duration is not None:
        raise InputError("--ela-chronology sets the ELA and the duration: drop --ela and --duration.")
    if run.from_ka is None:
        raise InputError("--ela-chronology needs --from (the age in ka where the run starts).")
    if run.ela_present is None:
        raise InputError("--ela-chronology needs --ela-present (today's ELA in m).")
    if (run.ela_glacial is None) == (run.ela_lapse_rate is None):
        raise InputError("--ela-chronology needs one of --ela-glacial (the ELA at the last glacial maximum, "
                         "m) or --ela-lapse-rate (m/K, with a temperature chronology).")
    if run.ela_lapse_rate is not None and run.ela_kind != "temperature":
        raise InputError("--ela-lapse-rate needs --ela-kind temperature.")
    if run.ela_kind not in ela_model.ELA_KINDS:
        raise InputError(f"--ela-kind must be one of {', '.join(ela_model.ELA_KINDS)}, got {run.ela_kind!r}.")


def chronology_ela(run: GlacierRun, series: Series) -> coupled.ElaTable:
    """The ELA through the run from the proxy ``series`` of ``--ela-chronology`` (``climate.ela``:
    linear in the proxy between today and the last glacial maximum, or a lapse rate on a
    temperature), as a table of years since ``--from``."""
    assert run.from_ka is not None and run.ela_present is not None
    try:
        if run.ela_lapse_rate is not None:
            values = ela_model.ela_from_temperature(series, run.ela_lapse_rate, run.ela_present,
                                                    series.age_ka)
        else:
            assert run.ela_glacial is not None
            values = ela_model.ela_from_proxy(series, run.ela_kind, run.ela_present, run.ela_glacial,
                                              series.age_ka)
        times, ela = ela_model.ela_table(series.age_ka, values, run.from_ka, run.to_ka,
                                         str(run.ela_chronology))
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    return coupled.ElaTable(times, ela)


def duration(run: GlacierRun) -> float | None:
    """Simulated years: ``--duration``, or from ``--from`` to ``--to`` along a chronology."""
    if run.from_ka is not None and run.ela_chronology is not None:
        return (run.from_ka - run.to_ka) * YEARS_PER_KA
    return run.duration


def _snapshot_times(run: GlacierRun) -> list[float]:
    """Times (y) of the ice snapshots: every ``--snapshot-every`` years of the run."""
    span = duration(run)
    if run.diagnostic or run.snapshot_every is None or span is None:
        return []
    count = math.floor(span / run.snapshot_every * (1.0 + 1e-12))
    return [k * run.snapshot_every for k in range(1, count + 1)]


def chronology_png_path(output: Path) -> Path:
    """The chronology plot of a run along ``--ela-chronology``: OUT_chronology.png."""
    return output.with_name(f"{output.stem}_chronology.png")


def snapshot_base(run: GlacierRun) -> Path:
    """Ice snapshots are numbered after ``--ice``, else after ``OUT_ice``."""
    assert run.output is not None
    return run.ice or run.output.with_name(f"{run.output.stem}_ice{run.output.suffix}")


def _check_outputs(run: GlacierRun, snapshot_times: list[float], write: WriteOptions) -> None:
    """Clear every output before any work: rasters, plots and the timeline."""
    inputs = tuple(p for p in (run.source, run.ice_thickness) if p is not None)
    rasters = [p for p in (run.output, run.ice, run.velocity, run.sliding, run.lakes) if p is not None]
    if snapshot_times:
        rasters += [snapshot_path(snapshot_base(run), k) for k in range(1, len(snapshot_times) + 1)]
    pngs = [p for p in (run.preview,) if p is not None]
    if run.ela_chronology is not None:
        assert run.output is not None
        pngs.append(chronology_png_path(run.output))
    paths = rasters + pngs + [p for p in (run.timeline,) if p is not None]
    if len(set(map(Path.resolve, paths))) != len(paths):
        raise InputError("two outputs have the same path.")
    if run.velocity is not None and run.velocity.suffix.lower() not in (".tif", ".tiff"):
        raise InputError("the velocity output has two bands and must be a GeoTIFF (.tif), "
                         f"got {run.velocity.name}.")
    for path in rasters:
        check_raster(path, write, run.replaces, inputs)
    if run.snapshots_nc is not None:
        check_series(run.snapshots_nc, bool(snapshot_times), "--snapshot-every", run.replaces, inputs)
    for png in pngs:
        check_png(png, run.replaces, inputs)
    if run.timeline is not None:
        check_output(run.timeline, run.replaces, inputs)


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
    return resolve(ELA_SPEC, text, terrain, files="a raster or a CSV table")


def sliding_coefficient(text: str, terrain: Terrain) -> float | np.ndarray:
    """``--sliding-C``: ``inf`` (frozen bed), a number ≥ 0 or a raster (Pa·(y/m)^(σ−1))."""
    if text.strip().lower() in ("inf", "+inf", "infinity"):
        return math.inf
    return resolve(SLIDING_SPEC, text, terrain)
