"""A `particle-erode` job (003): plan (check everything, read inputs, build the terrain, the
emission and the medium) then run the particles and write the outputs.

Inputs: the DEM is the ground surface (m). A layered terrain (003 §4.2) adds a multi-band
raster of layer thicknesses (m, bottom layer first) and a materials table; the base of the
stack is the surface minus the total thickness. A voxel terrain (003 §4.4: density or binary
voxels) is a block built from the DEM (columns of about ``--voxel-size`` over its extent, from
``--depth`` below its lowest cell to ``--headroom`` above its highest, CRS and origin kept),
with 3D material layers from a YAML of horizons, or a volume read from ``--voxels`` (an .npz,
``io.voxel_files``). An implicit terrain (003 §4.3: a signed distance function altered by
metaballs) has the DEM's surface, or the scene of ``--sdf`` (``io.sdf_scene``), as its base,
and its cache of nodes on the block the DEM would give. Several kinds of particles run
together (003 Fig. 8) from ``--preset A+B+…`` or ``--kinds`` (``io.particle_kinds``).
Outputs: the new surface (a DEM like the input; on voxels and implicit terrains the highest
ground surface of each column, on the volume's columns), optionally the change map Δh (m), the
layers (thicknesses in the input's format, the deposit layer on top) or the altered volume and
its surface mesh, and a GeoJSON of sampled particle paths. The JSON sidecar holds the mass
budget (m³) and the particle counts.

Mass budget (``particles.ParticleBudget``): emitted + detached − deposited − suspended − lost
= 0 up to rounding, and the terrain's volume changes by deposited − detached. ``emitted`` is
matter added by design (the particles' ``initial_load``: the volcano preset) and
``suspended`` matter removed by design (``keep_suspended``: the coastal preset's corrosion);
for the other presets both are 0 and detached = deposited + lost.
"""

from __future__ import annotations

import contextlib
import json
import math
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import load_on_grid, read_bands_on_grid, write_bands
from unerode_cli.io.material_files import read_materials
from unerode_cli.io.mesh_files import mesh_format, write_mesh
from unerode_cli.io.particle_kinds import KindSpec, read_particle_kinds
from unerode_cli.io.particle_paths import grid_to_map, write_paths
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.provenance import history_entry, write_sidecar
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.river_files import read_river_line
from unerode_cli.io.sdf_scene import read_sdf_scene
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.voxel_files import (
    VOXEL_SUFFIX,
    MaterialLayers,
    VoxelFile,
    read_material_layers,
    read_voxels,
    voxel_file_layout,
    write_voxels,
)
from unerode_cli.particles import (
    APPLY_MODES,
    IMPLICIT_REPRESENTATIONS,
    PARAMETERS,
    PER_IMPACT,
    PER_ITERATION,
    REPRESENTATIONS,
    VOXEL_REPRESENTATIONS,
    BinaryTerrain,
    DensityTerrain,
    Emission,
    HeightfieldTerrain,
    LayeredTerrain,
    Material,
    MaterialRules,
    ParticleKind,
    ParticleParams,
    ParticleRun,
    Preset,
    SdfTerrain,
    VelocityField,
    get_preset,
    run_bytes,
    sdf_run_bytes,
)
from unerode_cli.particles import Terrain as ParticleTerrain
from unerode_cli.run.divergence import DivergenceGuard
from unerode_cli.run.outputs import Outputs, check_png, check_raster, field_preview, save
from unerode_cli.run.parameter_maps import resolve
from unerode_cli.viz.particles_preview import save_particles_preview
from unerode_cli.volume.mesh import MeshExtraMissing, enclosed_volume, marching_cubes_function
from unerode_cli.volume.voxels import (
    BinaryVoxels,
    DensityVoxels,
    VoxelGeometry,
    binary_block,
    block_geometry,
    column_heights,
    density_block,
    ground_mesh,
    horizon_material,
    vertex_normals,
)

COMMAND = "particle-erode"
#: Meander field of ``--velocity sin`` without numbers: 1 m/s, a quarter of the DEM's width.
SIN_AMPLITUDE = 1.0
SIN_WAVES_PER_WIDTH = 4.0
#: A block built from a DEM reaches this many voxels below its lowest cell and above its
#: highest one unless --depth / --headroom say otherwise.
DEFAULT_DEPTH_VOXELS = 10
DEFAULT_HEADROOM_VOXELS = 10
#: Memory a voxel run may take unless --memory-budget says otherwise (GiB).
DEFAULT_MEMORY_BUDGET_GIB = 4.0
#: The terrains impacts can alter as they happen (``Terrain.live_state``).
PER_IMPACT_REPRESENTATIONS = ("heightfield", "density", "binary")
_VOXEL_OPTIONS = (("voxel_size", "--voxel-size"), ("depth", "--depth"), ("headroom", "--headroom"),
                  ("voxels", "--voxels"), ("volume_out", "--volume-out"), ("mesh", "--mesh"),
                  ("hits_per_voxel", "--hits-per-voxel"), ("hits_threshold", "--hits-threshold"))
#: Options of voxels that an implicit terrain (one material, no hit counts) does not take.
_NOT_IMPLICIT = (("voxels", "--voxels"), ("hits_per_voxel", "--hits-per-voxel"),
                 ("hits_threshold", "--hits-threshold"), ("materials", "--materials"),
                 ("deposit_material", "--deposit-material"))


@dataclass(frozen=True)
class ParticleJob:
    """What the user asked for. Texts are parsed in ``plan``; None = the preset's value.
    ``preset`` may name several presets joined by "+" (None: rain, or the kinds of ``kinds``).

    Attributes (units): ``outputs`` the output DEM and its write options; ``sources`` "X,Y" map
    coordinates in the DEM's CRS (m or degrees) or one GeoJSON/WKT line file; ``spread`` m;
    ``velocity`` "uniform:VE,VN[,VU]" (m/s), "sin[:AMPLITUDE,WAVELENGTH]" (m/s, m) or a 2/3-band
    raster path; ``emission_velocity`` "VE,VN[,VU]" (m/s); ``sea_level`` m; ``path_stride``
    steps; ``representation`` heightfield, layers, density, binary or sdf (None: from the inputs
    and the preset); ``voxel_size``, ``depth``, ``headroom`` m; ``memory_budget`` GiB;
    ``hits_per_voxel`` α (hits per voxel volume) and ``hits_threshold`` C (hits) of binary voxels;
    ``apply`` when impacts alter the terrain, per-iteration or per-impact (``particles.APPLY_MODES``).
    """

    source: Path
    outputs: Outputs
    preset: str | None = None
    particles: int | None = None
    iterations: int | None = None
    seed: int = 0
    emission: str | None = None
    sources: tuple[str, ...] = ()
    spread: float | None = None
    rain_mask: Path | None = None
    emission_velocity: str | None = None
    velocity: str | None = None
    velocity_medium: str | None = None
    sea_level: float | None = None
    layers: Path | None = None
    materials: Path | None = None
    layer_materials: str | None = None
    deposit_material: str | None = None
    layers_out: Path | None = None
    change_map: Path | None = None
    paths: Path | None = None
    path_count: int = 100
    path_stride: int = 4
    threads: int | None = None
    band: int | None = None
    channel: str | None = None
    parameter_values: dict[str, str | None] = field(default_factory=dict)
    representation: str | None = None
    voxel_size: float | None = None
    depth: float | None = None
    headroom: float | None = None
    voxels: Path | None = None
    volume_out: Path | None = None
    mesh: Path | None = None
    memory_budget: float = DEFAULT_MEMORY_BUDGET_GIB
    hits_per_voxel: float | None = None
    hits_threshold: int | None = None
    sdf: Path | None = None
    kinds: Path | None = None
    apply: str = PER_ITERATION


@dataclass(frozen=True)
class VoxelSetup:
    """A 3D terrain (voxels or implicit) and what its outputs need: ``surface`` its top
    heightfield before the run, georeferenced (the reference of the emission, the medium and
    the outputs), the CRS WKT and the material names of the volume, and what it was built from
    (``description``)."""

    terrain: DensityTerrain | BinaryTerrain | SdfTerrain
    surface: Terrain
    crs_wkt: str
    material_names: tuple[str, ...]
    description: str


@dataclass
class PreparedParticleJob:
    """A checked job: inputs read, terrain, kinds of particles (parameters, emission and
    medium; ``params``, ``emission`` and ``velocity`` are the first kind's) built, every output
    path cleared."""

    job: ParticleJob
    dem: Terrain
    terrain: ParticleTerrain
    params: ParticleParams
    emission: Emission
    velocity: VelocityField | None
    iterations: int
    outputs: Outputs
    layers_out: Path | None
    provenance: dict[str, Any]
    notes: list[str]
    surface: Terrain
    volume: VoxelSetup | None = None
    kinds: tuple[ParticleKind, ...] = ()


@contextlib.contextmanager
def bad_input() -> Iterator[None]:
    """Turn the particles package's ValueError (one sentence) into bad input (exit 2)."""
    try:
        yield
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None


def change_preview_path(change_map: Path) -> Path:
    """``dh.tif`` → ``dh.png``: the change map's preview, written when --preview is given."""
    return change_map.with_suffix(".png")


def default_layers_path(output: Path) -> Path:
    """``OUT.tif`` → ``OUT_layers.tif`` (always a GeoTIFF: layers are multi-band)."""
    return output.with_name(f"{output.stem}_layers.tif")


def plan(job: ParticleJob) -> PreparedParticleJob:
    """Check the whole job before any work: options, outputs, inputs, parameters."""
    specs, file_iterations = _kind_specs(job)
    presets = [get_preset(spec.preset) for spec in specs]
    preset = presets[0]
    representation = _representation(job, preset)
    _check_terrain_options(job, representation)
    _check_apply(job, representation)
    outputs = job.outputs
    inputs = tuple(p for p in (job.source, job.layers, job.materials, job.rain_mask, job.voxels, job.sdf,
                               job.kinds) if p is not None)
    outputs.check(*inputs)
    layers_out = None
    if job.layers is not None:
        layers_out = job.layers_out or default_layers_path(outputs.path)
        if layers_out.suffix.lower() not in (".tif", ".tiff"):
            raise InputError(f"the layers output must be a GeoTIFF (.tif), got {layers_out.name}.")
    rasters = [p for p in (job.change_map, layers_out) if p is not None]
    pngs = [change_preview_path(job.change_map)] if job.change_map and outputs.preview else []
    files = [p for p in (job.paths, job.volume_out, job.mesh) if p is not None]
    extra = [*rasters, *pngs, *files]
    if len(set(map(Path.resolve, [outputs.path, *extra]))) != len(extra) + 1:
        raise InputError("two outputs have the same path.")
    for path in rasters:
        check_raster(path, outputs.options, outputs.overwrite, inputs)
    for path in pngs:
        check_png(path, outputs.overwrite, inputs)
    for path in files:
        check_output(path, outputs.overwrite, inputs)
    _check_counts(job)
    _check_sources(job)
    dem = read_terrain(job.source, band=job.band, channel=job.channel)
    dem.check_valid(job.source)
    outputs.check_source(dem, job.source)
    notes: list[str] = []
    volume = None
    if representation in VOXEL_REPRESENTATIONS:
        volume = voxel_setup(job, dem, representation, notes)
    elif representation in IMPLICIT_REPRESENTATIONS:
        volume = sdf_setup(job, dem)
    surface = dem if volume is None else volume.surface
    grid = surface.grid
    several = len(specs) > 1
    kinds = tuple(particle_kind(job, p, spec, surface, notes, several)
                  for p, spec in zip(presets, specs, strict=True))
    params, emission, velocity = kinds[0].params, kinds[0].emission, kinds[0].velocity
    terrain: ParticleTerrain
    if volume is not None:
        terrain = volume.terrain
    elif representation == "layers":
        terrain = layered_terrain(job, dem, notes)
    else:
        with bad_input():
            terrain = HeightfieldTerrain(np.nan_to_num(dem.elevation), grid)
    with bad_input():
        for kind in kinds:
            for part in (kind.params, kind.emission, kind.velocity):
                if part is not None:
                    part.validate(grid)
    iterations = job.iterations or file_iterations or max(p.iterations for p in presets)
    provenance = {
        "input": job.source, "preset": "+".join(p.name for p in presets), "representation": representation,
        "particles_per_iteration": sum(kind.emission.count for kind in kinds), "iterations": iterations,
        "rain_mask": job.rain_mask, "sea_level_m": job.sea_level, "layers": job.layers,
        "materials": job.materials, "sdf_scene": job.sdf, "kinds_file": job.kinds, "apply": job.apply,
    }
    described = [_kind_provenance(job, p, spec, kind, surface)
                 for p, spec, kind in zip(presets, specs, kinds, strict=True)]
    if several:
        provenance["kinds"] = described
    else:
        provenance.update(described[0])
    if isinstance(terrain, LayeredTerrain):
        provenance["layer_materials"] = [terrain.materials[m].name for m in terrain.layer_material]
        provenance["deposit_material"] = terrain.materials[terrain.deposit_material].name
    if volume is not None:
        provenance.update(_volume_provenance(volume))
    return PreparedParticleJob(job, dem, terrain, params, emission, velocity, iterations, outputs,
                               layers_out, provenance, notes, surface, volume, kinds)


def _kind_specs(job: ParticleJob) -> tuple[list[KindSpec], int | None]:
    """The kinds of particles of the run, in order, and the iterations their file asks for:
    ``--kinds``' file, or the presets of ``--preset`` joined by "+" (default rain)."""
    if job.kinds is not None:
        if job.preset is not None:
            raise InputError("give the kinds of particles with --preset or with --kinds, not both.")
        spec = read_particle_kinds(job.kinds)
        return list(spec.kinds), spec.iterations
    names = (job.preset or "rain").split("+")
    with bad_input():
        for name in names:
            get_preset(name)
    return [KindSpec(preset=name) for name in names], None


def particle_kind(job: ParticleJob, preset: Preset, spec: KindSpec, surface: Terrain, notes: list[str],
                  several: bool) -> ParticleKind:
    """A kind of particles: the preset's values, the spec's and then the command line's
    parameters; its emission (``several``: one kind among others) and medium velocity."""
    params = particle_params(preset, job.parameter_values, surface, spec.parameters)
    emission = build_emission(job, preset, params, surface, notes, count=spec.particles, several=several)
    velocity = build_velocity(job, preset, surface, _velocity_text(job, preset, spec))
    return ParticleKind(params, emission, velocity, preset.name)


def _velocity_text(job: ParticleJob, preset: Preset, spec: KindSpec) -> str | None:
    """The medium velocity of a kind in the words of --velocity: the kind's, else --velocity,
    else the preset's (None: still medium)."""
    return spec.velocity or job.velocity or preset.velocity or None


def _kind_provenance(job: ParticleJob, preset: Preset, spec: KindSpec, kind: ParticleKind,
                     surface: Terrain) -> dict[str, Any]:
    emission, velocity = kind.emission, kind.velocity
    return {"kind": kind.name, "particles_per_iteration": emission.count, "emission": emission.kind,
            "source_points": _points(emission, surface), "spread_m": emission.spread,
            "emission_velocity_m_s": emission.velocity, "velocity": _velocity_text(job, preset, spec),
            "velocity_medium": None if velocity is None else velocity.medium, **asdict(kind.params)}


def _representation(job: ParticleJob, preset: Preset) -> str:
    """The terrain representation: --representation, else that of --voxels' file, else sdf
    with --sdf, else "layers" with --layers, else the (first) preset's."""
    if job.representation is not None:
        if job.representation not in REPRESENTATIONS:
            raise InputError(f"unknown representation '{job.representation}'; choose "
                             f"{', '.join(REPRESENTATIONS[:-1])} or {REPRESENTATIONS[-1]}.")
        return job.representation
    if job.sdf is not None:
        return "sdf"
    if job.voxels is not None:
        return voxel_file_layout(job.voxels)[1]
    return "layers" if job.layers is not None else preset.representation


def _check_terrain_options(job: ParticleJob, representation: str) -> None:
    """The options of one representation are refused with another."""
    if representation == "layers":
        if job.layers is None or job.materials is None:
            raise InputError("a layered terrain needs both --layers (thicknesses) and --materials (table).")
    elif job.layers is not None or job.layer_materials or job.layers_out:
        raise InputError(f"--layers, --layer-materials and --layers-out describe a layered terrain, not "
                         f"a {representation} one.")
    if job.sdf is not None and representation != "sdf":
        raise InputError(f"--sdf gives an implicit terrain (--representation sdf), not a {representation} "
                         "one.")
    if representation in IMPLICIT_REPRESENTATIONS:
        given = [option for name, option in _NOT_IMPLICIT if getattr(job, name) is not None]
        if given:
            raise InputError(f"{', '.join(given)} describe voxels; an implicit terrain is built from the DEM "
                             "or --sdf and has one material (--k-eps, --tau-c).")
    if representation in VOXEL_REPRESENTATIONS + IMPLICIT_REPRESENTATIONS:
        if job.voxels is not None:
            given = [option for name, option in _VOXEL_OPTIONS[:3] if getattr(job, name) is not None]
            if given:
                raise InputError(f"{', '.join(given)} build a block from the DEM; --voxels brings its own "
                                 "grid.")
        if representation == "density" and (job.hits_per_voxel is not None or job.hits_threshold is not None):
            raise InputError("--hits-per-voxel and --hits-threshold are for binary voxels.")
        for value, option, low in ((job.voxel_size, "--voxel-size", 0.0), (job.depth, "--depth", -1.0),
                                   (job.headroom, "--headroom", -1.0),
                                   (job.hits_per_voxel, "--hits-per-voxel", 0.0)):
            if value is not None and not (math.isfinite(value) and value > low):
                raise InputError(f"{option} must be a {'positive' if low == 0 else 'non-negative'} number, "
                                 f"got {value}.")
        if job.hits_threshold is not None and job.hits_threshold < 1:
            raise InputError(f"--hits-threshold must be at least 1, got {job.hits_threshold}.")
        if not (math.isfinite(job.memory_budget) and job.memory_budget > 0):
            raise InputError(f"--memory-budget must be a positive number of GiB, got {job.memory_budget}.")
        if job.volume_out is not None and job.volume_out.suffix.lower() != VOXEL_SUFFIX:
            raise InputError(f"--volume-out writes a {VOXEL_SUFFIX} file, not '{job.volume_out.name}'.")
        if job.mesh is not None:
            try:
                mesh_format(job.mesh)
                marching_cubes_function()
            except (ValueError, MeshExtraMissing) as exc:
                raise InputError(f"--mesh: {str(exc).rstrip('.')}.") from None
        return
    if representation == "heightfield" and (job.materials is not None or job.deposit_material):
        raise InputError("--materials and --deposit-material need a layered terrain (--layers) or voxels "
                         "(--representation density or binary).")
    given = [option for name, option in _VOXEL_OPTIONS if getattr(job, name) is not None]
    if given:
        raise InputError(f"{', '.join(given)} need a 3D terrain (--representation density, binary or sdf).")


def _check_apply(job: ParticleJob, representation: str) -> None:
    """``--apply``: one of ``APPLY_MODES``; per-impact on heightfields and density and binary voxels."""
    if job.apply not in APPLY_MODES:
        raise InputError(f"--apply must be {' or '.join(APPLY_MODES)}, got '{job.apply}'.")
    if job.apply == PER_IMPACT and representation not in PER_IMPACT_REPRESENTATIONS:
        raise InputError(f"--apply per-impact works on {', '.join(PER_IMPACT_REPRESENTATIONS)} terrains, "
                         f"not on a {representation} one.")


def _check_counts(job: ParticleJob) -> None:
    for option, value, low in (("--particles", job.particles, 1), ("--iterations", job.iterations, 1),
                               ("--path-count", job.path_count, 1), ("--path-stride", job.path_stride, 1),
                               ("--threads", job.threads, 1)):
        if value is not None and value < low:
            raise InputError(f"{option} must be at least {low}, got {value}.")
    if not 0 <= job.seed < 2**64:
        raise InputError(f"--seed must be an integer in [0, 2^64), got {job.seed}.")
    if job.sea_level is not None and not math.isfinite(job.sea_level):
        raise InputError(f"--sea-level must be a finite elevation (m), got {job.sea_level}.")
    if job.spread is not None and not (math.isfinite(job.spread) and job.spread >= 0):
        raise InputError(f"--spread must be a distance ≥ 0 m, got {job.spread}.")


def _check_sources(job: ParticleJob) -> None:
    """``--source``: X,Y points (repeated for a line) or one line file that exists."""
    if len(job.sources) == 1 and "," not in job.sources[0] and not Path(job.sources[0]).is_file():
        raise InputError(f"--source takes X,Y points in the DEM's CRS (repeat it for a line) or a "
                         f"GeoJSON/WKT line file, and '{job.sources[0]}' is neither.")


def particle_params(preset: Preset, given: dict[str, str | None], dem: Terrain,
                    values: Mapping[str, float] | None = None) -> ParticleParams:
    """The preset's parameters on the DEM's cells (R in cells × the mean cell size), with
    ``values`` (a kind's, SI units) and then the values given on the command line (SI units,
    checked against ``particles.PARAMETERS``) replacing them."""
    overrides = {spec.name: float(resolve(spec, text, dem))
                 for spec in PARAMETERS if (text := given.get(spec.name)) is not None}
    with bad_input():
        return preset.params(0.5 * (dem.dx + dem.dy), **{**(values or {}), **overrides})


def _numbers(text: str, counts: tuple[int, ...], what: str) -> list[float]:
    """Comma-separated finite numbers, as many as one of ``counts``."""
    try:
        values = [float(part) for part in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in counts or not all(math.isfinite(v) for v in values):
        wanted = " or ".join(str(c) for c in counts)
        raise InputError(f"{what} expects {wanted} comma-separated numbers, got '{text}'.")
    return values


def _map_to_grid(dem: Terrain, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(column, row) grid coordinates (cell centres at integers) of map coordinates: float[k, 2]."""
    cols, rows = ~dem.transform * (np.asarray(x, float), np.asarray(y, float))
    return np.column_stack([np.atleast_1d(cols) - 0.5, np.atleast_1d(rows) - 0.5])


def _points(emission: Emission, dem: Terrain) -> list[list[float]] | None:
    if emission.points is None:
        return None
    x, y = grid_to_map(dem, emission.points[:, 0], emission.points[:, 1])
    return np.column_stack([x, y]).tolist()


def source_points(job: ParticleJob, dem: Terrain, notes: list[str]) -> np.ndarray:
    """Grid coordinates float[k, 2] of the source: ``--source X,Y`` (repeated: a line), a line
    file, or the highest cell of the DEM when none is given."""
    if not job.sources:
        row, col = np.unravel_index(np.nanargmax(dem.elevation), dem.shape)
        x, y = grid_to_map(dem, col, row)
        notes.append(f"note: no --source given: particles start at the highest cell ({float(x):.1f}, "
                     f"{float(y):.1f}).")
        return np.array([[float(col), float(row)]])
    if len(job.sources) == 1 and "," not in job.sources[0]:
        x, y = read_river_line(Path(job.sources[0]))
    else:
        xy = np.array([_numbers(text, (2,), "--source") for text in job.sources])
        x, y = xy[:, 0], xy[:, 1]
    return _map_to_grid(dem, x, y)


def build_emission(job: ParticleJob, preset: Preset, params: ParticleParams, dem: Terrain,
                   notes: list[str], count: int | None = None, several: bool = False) -> Emission:
    """Rain over the domain (or weighted by ``--rain-mask``) or a source point / line, with
    ``count`` particles per iteration (default: --particles, else the preset's). A kind among
    ``several`` emits as its preset does unless --emission says otherwise, --source and
    --rain-mask going to the kinds that emit that way."""
    kind = job.emission or ("source" if job.sources and not several else preset.emission)
    if kind not in ("rain", "source"):
        raise InputError(f"--emission must be rain or source, got '{kind}'.")
    if kind == "rain" and job.sources and not several:
        raise InputError("--source needs --emission source (or a preset that emits from a source).")
    if kind == "source" and job.rain_mask is not None and not several:
        raise InputError("--rain-mask needs rain emission (--emission rain).")
    count = count or (preset.particles if job.particles is None else job.particles)
    velocity = (0.0, 0.0, 0.0)
    if job.emission_velocity is not None:
        velocity = tuple(_numbers(job.emission_velocity, (2, 3), "--emission-velocity") + [0.0])[:3]
    if kind == "rain":
        mask = None
        if job.rain_mask is not None:
            weights = load_on_grid(job.rain_mask, dem, "rain mask")
            holes = int((np.isnan(weights) & dem.grid.valid).sum())
            if holes:
                notes.append(f"note: the rain mask {job.rain_mask} has {holes} nodata cell(s) inside the "
                             "DEM; no rain starts there (weight 0).")
            mask = np.nan_to_num(weights, nan=0.0)
        elif preset.rain_below_sea and job.sea_level is not None:
            mask = dem.grid.valid & (np.nan_to_num(dem.elevation, nan=np.inf) < job.sea_level)
            if not mask.any():
                raise InputError(f"no cell's ground lies below --sea-level {job.sea_level:g} m, where the "
                                 f"{preset.name} preset's particles start; give a --rain-mask.")
            notes.append(f"note: the {preset.name} preset's particles start over the {int(mask.sum())} "
                         "cell(s) "
                         f"whose ground is below --sea-level {job.sea_level:g} m.")
        return Emission.rain(count, mask, velocity=velocity)
    spread = params.radius if job.spread is None else job.spread
    return Emission.source(count, source_points(job, dem, notes), spread=spread, velocity=velocity)


def build_velocity(job: ParticleJob, preset: Preset, dem: Terrain, text: str | None) -> VelocityField | None:
    """The medium velocity field (003 Eq. 8) described by ``text`` in the words of
    ``--velocity``, acting in ``--velocity-medium`` or the preset's medium; None: still medium."""
    medium = job.velocity_medium or preset.field_medium
    if text is None:
        return None
    kind, _, numbers = text.partition(":")
    with bad_input():
        if kind == "uniform":
            return VelocityField.uniform(*_numbers(numbers, (2, 3), "--velocity uniform:"), medium=medium)
        if kind == "sin":
            values = (_numbers(numbers, (2,), "--velocity sin:") if numbers else
                      [SIN_AMPLITUDE, dem.shape[1] * dem.dx / SIN_WAVES_PER_WIDTH])
            return VelocityField.meander(*values, medium=medium)
        bands = read_bands_on_grid(Path(text), dem, "velocity").values
        if bands.shape[0] not in (2, 3):
            raise InputError(f"the velocity raster {text} has {bands.shape[0]} band(s); it needs 2 (east, "
                             f"north) or 3 (east, north, up) in m/s.")
        return VelocityField.raster(np.where(dem.grid.valid, bands, 0.0), medium=medium)


def layered_terrain(job: ParticleJob, dem: Terrain, notes: list[str]) -> LayeredTerrain:
    """The layered terrain (003 §4.2) of ``--layers`` and ``--materials`` under the DEM's surface.

    Layer materials: ``--layer-materials`` (names, bottom first), else the band descriptions
    when each names a material of the table, else the table's rows in order (one per band).
    Deposits become ``--deposit-material``, by default the top layer's material. What the
    materials table leaves to defaults is added to ``notes``.
    """
    assert job.layers is not None and job.materials is not None
    materials = read_materials(job.materials, on_note=notes.append)
    names = [m.name for m in materials]
    bands = read_bands_on_grid(job.layers, dem, "layers")
    valid = dem.grid.valid
    thickness = bands.values
    if not np.isfinite(thickness[:, valid]).all():
        raise InputError(f"the layers raster {job.layers} has nodata inside the DEM's domain.")
    n = thickness.shape[0]
    if job.layer_materials:
        chosen = [name.strip() for name in job.layer_materials.split(",")]
        if len(chosen) != n:
            raise InputError(f"--layer-materials names {len(chosen)} material(s) for {n} layer band(s).")
    elif all(d in names for d in bands.descriptions):
        chosen = list(bands.descriptions)
    elif len(materials) == n:
        chosen = names
    else:
        raise InputError(f"the layers raster has {n} band(s) and the materials table {len(materials)} "
                         f"row(s): name each band's material with --layer-materials.")
    deposit = job.deposit_material or chosen[-1]
    for name in [*chosen, deposit]:
        if name not in names:
            raise InputError(f"material '{name}' is not in the materials table {job.materials}.")
    thickness = np.where(valid, thickness, 0.0)
    base = np.where(valid, dem.elevation - thickness.sum(axis=0), 0.0)
    with bad_input():
        return LayeredTerrain(base, thickness, [names.index(c) for c in chosen], materials,
                              names.index(deposit), dem.grid)


def _check_memory(voxels: int, representation: str, with_material: bool, budget_gib: float,
                  what: str) -> None:
    """Refuse a voxel grid (or an implicit terrain's cache) whose run would need more than
    ``budget_gib`` GiB."""
    needed = (sdf_run_bytes(voxels) if representation in IMPLICIT_REPRESENTATIONS
              else run_bytes(voxels, representation, with_material))
    if needed > budget_gib * 2**30:
        raise InputError(f"{what} has {voxels:,} voxels, whose run needs about {needed / 2**30:.1f} GiB, "
                         "more "
                         f"than the {budget_gib:g} GiB of --memory-budget; use larger voxels or a smaller "
                         "area, or raise --memory-budget.")


def _voxel_materials(job: ParticleJob,
                     notes: list[str]) -> tuple[list[Material] | None, MaterialLayers | None]:
    """The materials of a voxel terrain: --materials as a CSV table (materials only) or a YAML
    of 3D material layers (``io.voxel_files``); (None, None) without --materials."""
    if job.materials is None:
        return None, None
    if job.materials.suffix.lower() in (".yaml", ".yml"):
        layers = read_material_layers(job.materials)
        return list(layers.materials), layers
    return read_materials(job.materials, on_note=notes.append), None


def _material_index(name: str, materials: list[Material], where: Path | None) -> int:
    names = [m.name for m in materials]
    if name not in names:
        raise InputError(f"material '{name}' is not in the materials table {where}.")
    return names.index(name)


def _block_frame(job: ParticleJob, dem: Terrain, representation: str, with_material: bool,
                 extent: tuple[float, float] | None = None) -> tuple[VoxelGeometry, np.ndarray, np.ndarray]:
    """The voxels of the block under the DEM (over its elevations and ``extent``, m, with
    --depth below and --headroom above), the DEM's heights at their columns and the columns
    inside the domain; its run's memory checked."""
    if not (math.isclose(dem.transform.a, dem.dx, rel_tol=1e-6) and math.isclose(-dem.transform.e, dem.dy,
                                                                                 rel_tol=1e-6)):
        raise InputError(f"{job.source} is not in a projected CRS in metres; a voxel block needs one "
                         "(reproject it, e.g. gdalwarp -t_srs EPSG:32632).")
    size = job.voxel_size or 0.5 * (dem.dx + dem.dy)
    valid = dem.grid.valid
    low, high = float(np.nanmin(dem.elevation)), float(np.nanmax(dem.elevation))
    if extent is not None:
        low, high = min(low, extent[0]), max(high, extent[1])
    depth = DEFAULT_DEPTH_VOXELS * size if job.depth is None else job.depth
    headroom = DEFAULT_HEADROOM_VOXELS * size if job.headroom is None else job.headroom
    ny, nx = dem.shape
    west, north = dem.transform.c, dem.transform.f
    with bad_input():
        geometry = block_geometry(west, north, nx * dem.dx, ny * dem.dy, low - depth, high + headroom, size)
    _check_memory(geometry.count, representation, with_material, job.memory_budget,
                  f"the block of {size:g} m voxels under {job.source.name}")
    heights, columns = column_heights(dem.elevation, valid, dem.dx, dem.dy, geometry.shape[:2])
    return geometry, heights, columns


def _block(job: ParticleJob, dem: Terrain, representation: str,
           with_material: bool) -> DensityVoxels | BinaryVoxels:
    """The block under the DEM (``volume.voxels.density_block`` / ``binary_block``)."""
    geometry, heights, columns = _block_frame(job, dem, representation, with_material)
    if representation == "density":
        return DensityVoxels(geometry, density_block(heights, geometry), valid=columns)
    return BinaryVoxels(geometry, binary_block(heights, geometry), valid=columns)


def _converted(voxels: DensityVoxels | BinaryVoxels, representation: str) -> DensityVoxels | BinaryVoxels:
    """The voxels as ``representation``: binary voxels read as densities ±1, densities as
    binary voxels where f > 0 (003 §4.4: one can be turned into the other)."""
    if representation == "density" and isinstance(voxels, BinaryVoxels):
        density = np.where(voxels.solid, 1.0, -1.0)
        return DensityVoxels(voxels.geometry, density, voxels.material, voxels.valid)
    if representation == "binary" and isinstance(voxels, DensityVoxels):
        return BinaryVoxels(voxels.geometry, voxels.density > 0.0, None, voxels.material, voxels.valid)
    return voxels


def _from_file(job: ParticleJob, representation: str, materials: list[Material] | None,
               layers: MaterialLayers | None) -> tuple[DensityVoxels | BinaryVoxels, VoxelFile]:
    """The volume of --voxels as ``representation``, its material indices those of ``materials``."""
    assert job.voxels is not None
    shape, _, has_material = voxel_file_layout(job.voxels)
    _check_memory(shape[0] * shape[1] * shape[2], representation, has_material or materials is not None,
                  job.memory_budget, f"the voxel file {job.voxels.name}")
    file = read_voxels(job.voxels)
    voxels = _converted(file.voxels, representation)
    if voxels.material is None:
        return voxels, file
    if materials is None:
        raise InputError(f"the voxel file {job.voxels} has a material index: give the materials' "
                         "erodibilities "
                         "with --materials.")
    if layers is not None and layers.tops:
        raise InputError(f"the voxel file {job.voxels} has its own material index; --materials gives "
                         "horizons, "
                         "which are for a block built from the DEM.")
    if file.material_names:
        lookup = np.array([_material_index(name, materials, job.materials) for name in file.material_names],
                          dtype=np.int16)
        voxels.material = lookup[voxels.material]
    elif int(voxels.material.max()) >= len(materials):
        raise InputError(f"the voxel file {job.voxels} uses material index {int(voxels.material.max())}, and "
                         f"the materials table {job.materials} has {len(materials)} material(s).")
    return voxels, file


def voxel_setup(job: ParticleJob, dem: Terrain, representation: str, notes: list[str]) -> VoxelSetup:
    """The voxel terrain (003 §4.4) of the job: --voxels' volume, or a block built from the DEM;
    its materials and material rules from --materials and --deposit-material."""
    materials, layers = _voxel_materials(job, notes)
    file = None
    if job.voxels is not None:
        voxels, file = _from_file(job, representation, materials, layers)
        crs_wkt = file.crs_wkt or dem.crs_wkt
        description = f"the volume {job.voxels.name}"
    else:
        voxels = _block(job, dem, representation, materials is not None)
        crs_wkt = dem.crs_wkt
        description = f"a block under {job.source.name}"
    if materials is not None and voxels.material is None:
        if layers is None or not layers.tops:
            raise InputError(f"the materials {job.materials} give no horizons to place in the volume: use a "
                             "YAML "
                             "of 3D material layers with 'horizons' (or a voxel file with a material index).")
        voxels.material = horizon_material(voxels.geometry, np.array(layers.tops),
                                           np.array(layers.horizon_materials))
    rules = MaterialRules()
    if materials is not None:
        deposit = (layers.deposit if layers is not None else None)
        if job.deposit_material:
            deposit = _material_index(job.deposit_material, materials, job.materials)
        elif deposit is None and layers is not None and layers.horizon_materials and file is None:
            deposit = layers.horizon_materials[-1]
        rules = MaterialRules(-1 if deposit is None else deposit, dict(layers.eroded) if layers else {})
    names = tuple(m.name for m in materials) if materials is not None else ()
    with bad_input():
        if representation == "density":
            terrain: DensityTerrain | BinaryTerrain = DensityTerrain(voxels, materials, rules)
        else:
            binary = {"alpha": job.hits_per_voxel, "threshold": job.hits_threshold}
            given = {k: v for k, v in binary.items() if v is not None}
            terrain = BinaryTerrain(voxels, materials, rules, **given)
    return VoxelSetup(terrain, _surface_raster(terrain, crs_wkt, dem), crs_wkt, names, description)


def sdf_setup(job: ParticleJob, dem: Terrain) -> VoxelSetup:
    """The implicit terrain (003 §4.3) of the job: the DEM's surface, or the scene of --sdf in
    the DEM's CRS, on the nodes of the block the DEM would give (--voxel-size, --depth,
    --headroom, reaching the scene's shapes)."""
    from unerode_cli.volume.sdf_field import ImplicitField
    from unerode_cli.volume.sdf_shapes import Surface, uses_surface

    scene = read_sdf_scene(job.sdf) if job.sdf is not None else Surface()
    geometry, heights, columns = _block_frame(job, dem, "sdf", False, scene.z_range())
    dx, dy, _ = geometry.size
    west, north, _ = geometry.origin
    with bad_input():
        field = ImplicitField(geometry, scene.framed(west + 0.5 * dx, north - 0.5 * dy),
                              heights if uses_surface(scene) else None)
        terrain = SdfTerrain(field, columns)
    description = (f"the scene {job.sdf.name} over {job.source.name}" if job.sdf is not None
                   else f"the surface of {job.source.name}")
    return VoxelSetup(terrain, _surface_raster(terrain, dem.crs_wkt, dem), dem.crs_wkt, (), description)


def _geometry(terrain: DensityTerrain | BinaryTerrain | SdfTerrain) -> VoxelGeometry:
    """The voxels of a 3D terrain (an implicit one's cache nodes)."""
    return terrain.geometry if isinstance(terrain, SdfTerrain) else terrain.voxels.geometry


def _surface_raster(terrain: DensityTerrain | BinaryTerrain | SdfTerrain, crs_wkt: str,
                    dem: Terrain) -> Terrain:
    """The top heightfield of a 3D terrain as a raster on its columns (NaN outside the
    domain), with the DEM's nodata value and tags."""
    geometry = _geometry(terrain)
    dx, dy, _ = geometry.size
    west, north, _ = geometry.origin
    elevation = np.where(terrain.grid.valid, terrain.surface(), np.nan)
    transform = Affine(dx, 0.0, west, 0.0, -dy, north)
    return Terrain(elevation, dx, dy, crs_wkt, transform, dem.nodata, dict(dem.tags))


def _volume_provenance(volume: VoxelSetup) -> dict[str, Any]:
    terrain = volume.terrain
    geometry = _geometry(terrain)
    info: dict[str, Any] = {"volume": volume.description, "voxel_size_m": list(geometry.size),
                            "voxel_shape_rows_columns_layers": list(geometry.shape),
                            "volume_origin_west_north_bottom_m": list(geometry.origin)}
    if volume.material_names:
        info["materials_3d"] = list(volume.material_names)
        deposit = terrain.rules.deposit
        info["deposit_material"] = volume.material_names[deposit] if deposit >= 0 else None
        info["eroded_becomes"] = {volume.material_names[a]: volume.material_names[b]
                                  for a, b in terrain.rules.eroded.items()}
    if isinstance(terrain, BinaryTerrain):
        info.update(hits_per_voxel=terrain.alpha, hits_threshold=terrain.threshold)
    return info


def run_job(prepared: PreparedParticleJob, on_iteration: Callable[[int], None] | None = None,
            on_note: Callable[[str], None] | None = None) -> str:
    """Run the particles, write the outputs, and return a one-line summary."""
    import numba

    from unerode_cli.particles import run_kinds

    job, dem = prepared.job, prepared.surface
    for note in prepared.notes:
        if on_note is not None:
            on_note(note)
    if job.threads is not None:
        numba.set_num_threads(min(job.threads, numba.config.NUMBA_NUM_THREADS))
    start = time.perf_counter()
    result = run_kinds(prepared.terrain, prepared.kinds, iterations=prepared.iterations, seed=job.seed,
                       sea_level=job.sea_level, paths=job.path_count if job.paths is not None else 0,
                       path_stride=job.path_stride, on_iteration=on_iteration, apply=job.apply)
    per_iteration = prepared.provenance["particles_per_iteration"]
    seconds = time.perf_counter() - start
    DivergenceGuard(dem.elevation, hint="lower the particle count or the erosion rates").check(
        result.elevation, 0.0, f"after {prepared.iterations} iterations")
    stats = statistics(result, dem, seconds, prepared.terrain)
    mesh_preview = prepared.volume is not None and prepared.outputs.preview is not None and _meshes()
    if prepared.volume is not None:
        _write_volume(result, prepared, stats, mesh_preview)
    surface = dem.with_elevation(result.elevation)
    save(surface, prepared.outputs, COMMAND, prepared.provenance, stats, seed=job.seed,
         elevation_preview=not mesh_preview)
    outputs = prepared.outputs
    if job.change_map is not None:
        save(dem.with_elevation(result.dh), Outputs(job.change_map, outputs.options, outputs.overwrite),
             COMMAND + " change", prepared.provenance, stats, seed=job.seed, elevation_preview=False)
        if outputs.preview is not None:
            field_preview(result.dh, dem, change_preview_path(job.change_map), "Δh (m)",
                          title=job.change_map.name, diverging=True)
    if prepared.layers_out is not None:
        _write_layers(result, prepared, stats)
    if job.paths is not None:
        write_paths(job.paths, result.paths, dem, per_iteration)
    b = result.budget
    return (f"{COMMAND}: {prepared.provenance['preset']} preset on {prepared.provenance['representation']}, "
            f"{result.stats.particles} particles "
            f"({prepared.iterations} × {per_iteration}), {result.stats.impacts} impacts in "
            f"{seconds:.2f} s; detached {b.detached:.4g} m³, deposited {b.deposited:.4g} m³, lost at "
            f"edges {b.lost:.4g} m³, suspended {b.suspended:.4g} m³, emitted {b.emitted:.4g} m³ "
            f"(residual {stats['mass_budget_m3']['relative_residual']:.1e}); wrote {outputs.path}")


def statistics(result: ParticleRun, dem: Terrain, seconds: float, terrain: ParticleTerrain) -> dict[str, Any]:
    """Run statistics for the sidecar: mass budget (m³), counts, Δh and speed; on 3D terrains
    the change of the volume's matter, what left the grid and the hits of binary voxels; with
    several kinds of particles the budget and counts of each."""
    b = result.budget
    scale = b.detached + b.emitted
    valid = dem.grid.valid
    dh = result.dh[valid]
    change = math.fsum(dh) * dem.dx * dem.dy
    extra: dict[str, Any] = {}
    if isinstance(result.terrain, DensityTerrain | BinaryTerrain | SdfTerrain):
        change = result.terrain.matter() - terrain.matter()
        extra["top_surface_volume_change"] = math.fsum(dh) * dem.dx * dem.dy
    if isinstance(result.terrain, DensityTerrain):
        extra["left_grid"] = result.terrain.left
    extra_stats: dict[str, Any] = {}
    if isinstance(result.terrain, BinaryTerrain) and isinstance(terrain, BinaryTerrain):
        extra_stats["binary_voxels"] = dict(zip(
            ("erosion_hits", "deposition_hits", "voxels_removed", "voxels_added", "voxels_transformed",
             "unplaced_hits"), (int(v) for v in result.terrain.counters), strict=True))
        extra_stats["binary_voxels"]["hits_held_change"] = int(
            result.terrain.voxels.hits.sum(dtype=np.int64) - terrain.voxels.hits.sum(dtype=np.int64))
    if len(result.kinds) > 1:
        extra_stats["kinds"] = [{"kind": k.name, "particles": k.stats.particles, "impacts": k.stats.impacts,
                                 "detached_m3": k.budget.detached, "deposited_m3": k.budget.deposited,
                                 "lost_at_edges_m3": k.budget.lost, "suspended_m3": k.budget.suspended,
                                 "emitted_m3": k.budget.emitted} for k in result.kinds]
    return {
        "mass_budget_m3": {
            "detached": b.detached, "deposited": b.deposited, "suspended": b.suspended,
            "lost_at_edges": b.lost, "emitted": b.emitted, "dropped": b.dropped,
            "residual": b.residual, "relative_residual": abs(b.residual) / scale if scale > 0 else 0.0,
            "terrain_volume_change": change, **extra,
        },
        **extra_stats,
        "mass_budget_note": (
            "emitted + detached - deposited - suspended - lost_at_edges = residual (0 up to rounding); "
            "the terrain's volume changes by deposited - detached (density voxels: by that less "
            "'left_grid', what went through the grid's top or bottom; binary voxels flip whole voxels "
            "at hits_threshold hits, so their change only follows it: (voxels_removed + voxels_transformed "
            "- voxels_added) * hits_threshold = erosion_hits - deposition_hits - hits_held_change exactly, "
            "and (erosion_hits - deposition_hits) / hits_per_voxel voxel volumes is detached - deposited "
            "but for the hits rounded down and unplaced; implicit terrains: the ground of the "
            "node cache, which misses what metaballs changed beyond the grid). 'emitted' is matter added "
            "by design "
            "(initial_load, e.g. the volcano preset), 'suspended' matter removed by design "
            "(keep_suspended, e.g. the coastal preset); 'dropped' is the part of 'deposited' left "
            "where particles died."),
        "particles": result.stats.particles, "impacts": result.stats.impacts,
        "settled": result.stats.settled, "left_domain": result.stats.lost, "expired": result.stats.expired,
        "mean_abs_change_m": float(np.abs(dh).mean()), "max_erosion_m": float(max(0.0, -dh.min())),
        "max_deposition_m": float(max(0.0, dh.max())), "wall_time_s": seconds,
        "particles_per_second": result.stats.particles / seconds if seconds > 0 else None,
    }


def _meshes() -> bool:
    """Whether surface meshes can be made (scikit-image is installed)."""
    try:
        marching_cubes_function()
    except MeshExtraMissing:
        return False
    return True


def _write_volume(result: ParticleRun, prepared: PreparedParticleJob, stats: dict[str, Any],
                  mesh_preview: bool) -> None:
    """--volume-out (the altered volume), --mesh (its ground's surface mesh) and, when
    ``mesh_preview``, --preview as a rendered view of that mesh, where overhangs and caves show
    (instead of the hillshade of the top surface, which is written without scikit-image)."""
    job, volume = prepared.job, prepared.volume
    terrain = result.terrain
    assert volume is not None and isinstance(terrain, DensityTerrain | BinaryTerrain | SdfTerrain)
    voxels = terrain.density_voxels() if isinstance(terrain, SdfTerrain) else terrain.voxels
    if job.volume_out is not None:
        write_voxels(job.volume_out, VoxelFile(voxels, volume.crs_wkt, volume.material_names))
    preview = prepared.outputs.preview if mesh_preview else None
    if job.mesh is None and preview is None:
        return
    mesh = ground_mesh(voxels)
    west, north, bottom = voxels.geometry.origin
    south = north - voxels.geometry.shape[0] * voxels.geometry.size[1]
    if job.mesh is not None:
        write_mesh(job.mesh, mesh, overwrite=True, origin=(west, south, bottom),
                   crs_wkt=volume.crs_wkt or None,
                   comments=(f"unerode-cli {COMMAND}: {volume.description}",
                             "material: the voxel's material index (0 without materials)"))
        stats["mesh"] = {"file": str(job.mesh), "vertices": len(mesh.vertices), "faces": len(mesh.faces),
                         "enclosed_volume_m3": enclosed_volume(mesh)}
    if preview is not None:
        with_materials = bool(volume.material_names)
        low = float(mesh.vertices[:, 2].min(initial=0.0))
        values = mesh.materials if with_materials else mesh.vertices[:, 2] - low
        label = ("material: " + ", ".join(f"{i} {n}" for i, n in enumerate(volume.material_names))
                 if with_materials else f"height above {bottom + low:.0f} m (m)")
        normals = vertex_normals(mesh.vertices, mesh.faces)
        with atomic_path(preview) as tmp:
            save_particles_preview(mesh.vertices, normals, values, tmp, label, min(voxels.geometry.size),
                                   title=f"{prepared.outputs.path.name}: {volume.description}",
                                   categorical=with_materials)


def _write_layers(result: ParticleRun, prepared: PreparedParticleJob, stats: dict[str, Any]) -> None:
    terrain = result.terrain
    assert isinstance(terrain, LayeredTerrain) and prepared.layers_out is not None
    names = [terrain.materials[m].name for m in terrain.layer_material]
    entry = history_entry(COMMAND + " layers", prepared.provenance, prepared.job.seed)
    tags = {"UNERODE_HISTORY": json.dumps([entry]), "UNERODE_LAYERS": "thickness (m), bottom layer first",
            "UNERODE_DEPOSIT_MATERIAL": names[-1]}
    write_bands(terrain.thickness, prepared.dem, prepared.layers_out, prepared.outputs.options, names, tags)
    write_sidecar(prepared.layers_out, entry, {**stats, "layer_materials": names})
