"""The kinds of particles of a `particle-erode` run (003 Fig. 8): each with its preset's values,
a kinds file's and the command line's parameters, its emission (rain or a source) and its
medium velocity field, on the grid of the terrain's surface."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import load_on_grid, read_bands_on_grid
from unerode_cli.io.particle_kinds import KindSpec, read_particle_kinds
from unerode_cli.io.particle_paths import grid_to_map
from unerode_cli.io.river_files import read_river_line
from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.particle_erode import parsers
from unerode_cli.jobs.particle_erode.checks import bad_input
from unerode_cli.particles import (
    PARAMETERS,
    Emission,
    ParticleKind,
    ParticleParams,
    Preset,
    VelocityField,
    get_preset,
)
from unerode_cli.run.parameter_maps import resolve


def kind_specs(job: Any) -> tuple[list[KindSpec], int | None]:
    """The kinds of particles of the run, in order, and the iterations their file asks for:
    ``--kinds``' file, or the presets of ``--preset`` joined by "+" (default rain)."""
    if job.kinds is not None:
        if job.preset is not None:
            raise InputError("give the kinds of particles with --preset or with --kinds, not both.")
        spec = read_particle_kinds(job.kinds)
        return list(spec.kinds), spec.iterations
    names = parsers.preset_names(job.preset)
    with bad_input():
        for name in names:
            get_preset(name)
    return [KindSpec(preset=name) for name in names], None


def velocity_text(job: Any, preset: Preset, spec: KindSpec) -> str | None:
    """The medium velocity of a kind in the words of --velocity: the kind's, else --velocity,
    else the preset's (None: still medium)."""
    return spec.velocity or job.velocity or preset.velocity or None


def velocity_rasters(job: Any, specs: list[KindSpec]) -> list[Path]:
    """The rasters the kinds' velocity fields are read from (inputs of the job)."""
    paths = []
    for spec in specs:
        text = velocity_text(job, get_preset(spec.preset), spec)
        try:
            described = parsers.velocity(text) if text is not None else None
        except ValueError:  # refused when the kind is built
            continue
        if described is not None and described.path is not None:
            paths.append(described.path)
    return paths


def particle_kind(job: Any, preset: Preset, spec: KindSpec, surface: Terrain, notes: list[str],
                  several: bool) -> ParticleKind:
    """A kind of particles: the preset's values, the spec's and then the command line's
    parameters; its emission (``several``: one kind among others) and medium velocity."""
    params = particle_params(preset, job.parameter_values(), surface, spec.parameters)
    emission = build_emission(job, preset, params, surface, notes, count=spec.particles, several=several)
    velocity = build_velocity(job, preset, surface, velocity_text(job, preset, spec))
    return ParticleKind(params, emission, velocity, preset.name)


def kind_provenance(job: Any, preset: Preset, spec: KindSpec, kind: ParticleKind,
                    surface: Terrain) -> dict[str, Any]:
    """What the history records of a kind: its name, emission (source points in the DEM's CRS,
    spread m, velocity m/s), medium velocity and parameters (SI units)."""
    emission, velocity = kind.emission, kind.velocity
    return {"kind": kind.name, "particles_per_iteration": emission.count, "emission": emission.kind,
            "source_points": _points(emission, surface), "spread_m": emission.spread,
            "emission_velocity_m_s": emission.velocity, "velocity": velocity_text(job, preset, spec),
            "velocity_medium": None if velocity is None else velocity.medium, **asdict(kind.params)}


def particle_params(preset: Preset, given: Mapping[str, str | None], dem: Terrain,
                    values: Mapping[str, float] | None = None) -> ParticleParams:
    """The preset's parameters on the DEM's cells (R in cells × the mean cell size), with
    ``values`` (a kind's, SI units) and then the values given on the command line (SI units,
    checked against ``particles.PARAMETERS``) replacing them."""
    overrides = {spec.name: float(resolve(spec, text, dem))
                 for spec in PARAMETERS if (text := given.get(spec.name)) is not None}
    with bad_input():
        return preset.params(0.5 * (dem.dx + dem.dy), **{**(values or {}), **overrides})


def _map_to_grid(dem: Terrain, x: Any, y: Any) -> np.ndarray:
    """(column, row) grid coordinates (cell centres at integers) of map coordinates: float[k, 2]."""
    cols, rows = ~dem.transform * (np.asarray(x, float), np.asarray(y, float))
    return np.column_stack([np.atleast_1d(cols) - 0.5, np.atleast_1d(rows) - 0.5])


def _points(emission: Emission, dem: Terrain) -> list[list[float]] | None:
    if emission.points is None:
        return None
    x, y = grid_to_map(dem, emission.points[:, 0], emission.points[:, 1])
    return np.column_stack([x, y]).tolist()


def source_points(job: Any, dem: Terrain, notes: list[str]) -> np.ndarray:
    """Grid coordinates float[k, 2] of the source: ``--source X,Y`` (repeated: a line), a line
    file, or the highest cell of the DEM when none is given."""
    sources = job.sources or ()
    if not sources:
        row, col = np.unravel_index(np.nanargmax(dem.elevation), dem.shape)
        x, y = grid_to_map(dem, col, row)
        notes.append(f"note: no --source given: particles start at the highest cell ({float(x):.1f}, "
                     f"{float(y):.1f}).")
        return np.array([[float(col), float(row)]])
    line = parsers.source_file(sources)
    if line is not None:
        x, y = read_river_line(line)
    else:
        with bad_input():
            x, y = parsers.source_xy(sources)
    return _map_to_grid(dem, x, y)


def _rain_mask(job: Any, preset: Preset, dem: Terrain, notes: list[str]) -> np.ndarray | None:
    """Weights of rain particles' start cells: --rain-mask (nodata: 0), or for a preset whose
    rain starts below sea level the cells under --sea-level; None: everywhere alike."""
    if job.rain_mask is not None:
        weights = load_on_grid(job.rain_mask, dem, "rain mask")
        holes = int((np.isnan(weights) & dem.grid.valid).sum())
        if holes:
            notes.append(f"note: the rain mask {job.rain_mask} has {holes} nodata cell(s) inside the "
                         "DEM; no rain starts there (weight 0).")
        return np.nan_to_num(weights, nan=0.0)
    if not (preset.rain_below_sea and job.sea_level is not None):
        return None
    mask = dem.grid.valid & (np.nan_to_num(dem.elevation, nan=np.inf) < job.sea_level)
    if not mask.any():
        raise InputError(f"no cell's ground lies below --sea-level {job.sea_level:g} m, where the "
                         f"{preset.name} preset's particles start; give a --rain-mask.")
    notes.append(f"note: the {preset.name} preset's particles start over the {int(mask.sum())} cell(s) "
                 f"whose ground is below --sea-level {job.sea_level:g} m.")
    return mask


def build_emission(job: Any, preset: Preset, params: ParticleParams, dem: Terrain,
                   notes: list[str], count: int | None = None, several: bool = False) -> Emission:
    """Rain over the domain (or weighted by ``--rain-mask``) or a source point / line, with
    ``count`` particles per iteration (default: --particles, else the preset's). A kind among
    ``several`` emits as its preset does unless --emission says otherwise, --source and
    --rain-mask going to the kinds that emit that way."""
    with bad_input("--emission"):
        kind = parsers.EMISSION.parse(job.emission or ("source" if job.sources and not several
                                                       else preset.emission))
    if kind == "rain" and job.sources and not several:
        raise InputError("--source needs --emission source (or a preset that emits from a source).")
    if kind == "source" and job.rain_mask is not None and not several:
        raise InputError("--rain-mask needs rain emission (--emission rain).")
    count = count or (preset.particles if job.particles is None else job.particles)
    with bad_input("--emission-velocity"):
        velocity = parsers.emission_velocity(job.emission_velocity)
    if kind == "rain":
        return Emission.rain(count, _rain_mask(job, preset, dem, notes), velocity=velocity)
    spread = params.radius if job.spread is None else job.spread
    return Emission.source(count, source_points(job, dem, notes), spread=spread, velocity=velocity)


def build_velocity(job: Any, preset: Preset, dem: Terrain, text: str | None) -> VelocityField | None:
    """The medium velocity field (003 Eq. 8) described by ``text`` in the words of
    ``--velocity``, acting in ``--velocity-medium`` or the preset's medium; None: still medium."""
    medium = job.velocity_medium or preset.field_medium
    if text is None:
        return None
    with bad_input():
        described = parsers.velocity(text)
        if described.kind == "uniform":
            return VelocityField.uniform(*described.numbers, medium=medium)
        if described.kind == "sin":
            values = described.numbers or parsers.sin_defaults(dem.shape[1] * dem.dx)
            return VelocityField.meander(*values, medium=medium)
        bands = read_bands_on_grid(Path(text), dem, "velocity").values
        if bands.shape[0] not in (2, 3):
            raise InputError(f"the velocity raster {text} has {bands.shape[0]} band(s); it needs 2 (east, "
                             f"north) or 3 (east, north, up) in m/s.")
        return VelocityField.raster(np.where(dem.grid.valid, bands, 0.0), medium=medium)
