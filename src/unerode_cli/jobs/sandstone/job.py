"""A `sandstone` job (002 Arenite): plan (check everything, read the scene or DEM, size the
particles and refuse what would not fit in memory), then run the frames and write OUT_DIR.

Outputs in OUT_DIR: ``particles.ply`` (binary; x y z, nx ny nz, viability, stress in MPa (−tr σ,
compression positive), erodibility E in 1/y, layer, surface, deposit, interlocked, vegetation),
``top.tif`` or ``top.exr`` (the top heightfield; a DEM's grid and CRS when extruded),
``preview.png``, ``frames.csv`` (one row per frame), ``run.json`` (parameters, seed, versions,
totals), and with ``--snapshot-every N`` the particles every N frames in ``snapshots/`` plus
``state.npz``, the state a ``--resume`` continues from. ``--mesh OUT.ply|OUT.obj`` adds the
closed surface mesh of the final particles, coloured by layer (its counts and enclosed volume go
to ``run.json``).
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.io.checkpoints import read_checkpoint, write_checkpoint
from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.json_files import to_json, write_json
from unerode_cli.io.mesh_files import mesh_format, write_mesh
from unerode_cli.io.particle_ply import write_particle_ply
from unerode_cli.io.paths import atomic_path, check_output
from unerode_cli.io.provenance import append_history, history_entry
from unerode_cli.io.rasters import read_terrain, write_terrain
from unerode_cli.io.scene_files import is_scene_file, read_scene
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.versions import io_library_versions
from unerode_cli.sandstone.deflation import DeflationParams
from unerode_cli.sandstone.deposition import DepositionParams
from unerode_cli.sandstone.fluvial import FluvialParams
from unerode_cli.sandstone.layers import LAYER_PARAMETERS, ROCK_PARAMETERS, Layer, LayerStack, Rock
from unerode_cli.sandstone.mpm import MpmParams
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.presets import PRESETS, preset_scene
from unerode_cli.sandstone.sampling import (
    ExtrudedDem,
    Lattice,
    lattice_for,
    memory_estimate,
    scene_particles,
    solid_particles,
    top_surface,
)
from unerode_cli.sandstone.scene import Scene, Water, Wind
from unerode_cli.sandstone.simulation import STAGES, FrameStats, Processes, Simulation, SimulationParams
from unerode_cli.sandstone.surface import surface_particles
from unerode_cli.sandstone.wind import WindParams
from unerode_cli.viz.particles_preview import save_particles_preview
from unerode_cli.volume.mesh import MeshExtraMissing, enclosed_volume, marching_cubes_function
from unerode_cli.volume.particle_surface import SMOOTHING, particle_mesh

COMMAND = "sandstone"
COLOR_BY = ("layer", "stress", "viability")
TOP_FORMATS = ("tif", "exr")
#: Share of the free memory a run may plan to use.
MEMORY_SHARE = 0.8
#: Headroom above an extruded DEM's highest cell, as a share of its height above the base.
DEM_HEADROOM = 0.25
FRAME_COLUMNS = ["frame", "particles", "eroded", "deposited", "exported", "surface", "interlocked_share",
                 "max_stress_mpa", "mpm_substeps", "mpm_residual", "eroded_fluvial", "discharge_max_m3y",
                 *(f"{s}_s" for s in STAGES)]
PARTICLES_FILE, FRAMES_FILE, RUN_FILE, STATE_FILE, PREVIEW_FILE = (
    "particles.ply", "frames.csv", "run.json", "state.npz", "preview.png")
SNAPSHOTS = "snapshots"


@dataclass(frozen=True)
class SandstoneJob:
    """What the user asked for. ``scene``: a scene YAML path, a preset name or a DEM path (with
    ``extrude``, the base altitude in m); ``dt`` years; wind azimuth and elevation in degrees,
    speed in m/s; ``alpha`` Pa; ``repose_angle`` degrees; ``precipitation`` m/y; ``sources``
    water sources (x, y, z in m, Q in m³/y) added to the scene's; None = the scene's or the
    default."""

    scene: str
    out_dir: Path
    extrude: float | None = None
    particles: int | None = None
    frames: int = 100
    dt: float = 1000.0
    seed: int = 0
    threads: int | None = None
    substeps: int = MpmParams.substeps
    settle_substeps: int = MpmParams.settle_substeps
    tolerance: float = MpmParams.tolerance
    processes: Processes = field(default_factory=Processes)
    wind_azimuth: float | None = None
    wind_elevation: float | None = None
    wind_speed: float | None = None
    alpha: float = DeflationParams.alpha
    repose_angle: float = DepositionParams.repose_angle
    precipitation: float | None = None
    sources: tuple[tuple[float, float, float, float], ...] = ()
    color_by: str = "layer"
    top_format: str = "tif"
    snapshot_every: int = 0
    mesh: Path | None = None
    mesh_smoothing: int = SMOOTHING
    resume: bool = False
    overwrite: bool = False
    band: int | None = None
    channel: str | None = None
    parameter_values: dict[str, str | None] = field(default_factory=dict)


@dataclass
class Source:
    """The rock to sample: a scene (a YAML file or a preset) or an extruded DEM."""

    description: str
    layers: LayerStack
    rock: Rock
    wind: Wind
    lattice: Lattice
    expected: float
    build: Callable[[int], Particles]
    dem: Terrain | None = None
    water: Water = field(default_factory=Water)


@dataclass
class PreparedSandstone:
    """A checked job: the source, the simulation's parameters, the outputs cleared."""

    job: SandstoneJob
    source: Source
    params: SimulationParams
    outputs: dict[str, Path]
    provenance: dict[str, Any]
    resume_state: dict[str, np.ndarray] | None = None


def plan(job: SandstoneJob) -> PreparedSandstone:
    """Check the whole job before any work: options, OUT_DIR, the scene or DEM, parameters, and
    whether the particles fit in memory (estimated, before sampling)."""
    _check_options(job)
    outputs = _output_paths(job)
    source = _source(job)
    layers, rock = _overridden(source.layers, source.rock, job.parameter_values)
    source.layers, source.rock = layers, rock
    wind = source.wind
    _check_sources(job, source)
    try:
        params = SimulationParams(
            dt=job.dt,
            mpm=MpmParams(substeps=job.substeps, settle_substeps=job.settle_substeps,
                          tolerance=job.tolerance),
            wind=WindParams(azimuth=_given(job.wind_azimuth, wind.azimuth),
                            elevation=_given(job.wind_elevation, wind.elevation),
                            speed=_given(job.wind_speed, wind.speed),
                            cone_angle=wind.cone_angle, rays=wind.rays),
            deflation=DeflationParams(alpha=job.alpha, cohesion=rock.cohesion, friction=rock.friction),
            deposition=DepositionParams(repose_angle=job.repose_angle,
                                        deposit_viability=rock.deposit_viability),
            fluvial=FluvialParams(precipitation=_given(job.precipitation, source.water.precipitation),
                                  sources=source.water.source_tuples() + job.sources),
            processes=job.processes)
    except ValueError as exc:
        raise InputError(f"{str(exc).rstrip('.')}.") from None
    _check_memory(source)
    provenance = {
        "scene": source.description, "particles_requested": job.particles,
        "particles_expected": source.expected, "lattice_spacing_m": source.lattice.spacing,
        "domain_low_m": source.lattice.low,
        "domain_size_m": source.lattice.size, "mpm_cell_m": source.lattice.mpm_grid().h,
        "frames": job.frames, "dt_years": job.dt, "layers": [asdict(layer) for layer in layers.layers],
        "deposit_layer": asdict(layers.deposit), "rock": asdict(rock), "mpm": asdict(params.mpm),
        "wind": asdict(params.wind), "deflation": asdict(params.deflation),
        "deposition": asdict(params.deposition), "fluvial": asdict(params.fluvial),
        "processes": asdict(params.processes),
    }
    if source.dem is not None:
        provenance["dem_transform"] = list(source.dem.transform)[:6]
        provenance["dem_crs_wkt"] = source.dem.crs_wkt
        provenance["coordinates"] = "x, y in m from the DEM's south-west corner; z in m"
    resume_state = _resume_state(job, outputs, provenance) if job.resume else None
    return PreparedSandstone(job, source, params, outputs, provenance, resume_state)


def _given(value: float | None, default: float) -> float:
    return default if value is None else value


def _check_sources(job: SandstoneJob, source: Source) -> None:
    """Refuse a --source whose point lies outside the domain."""
    low = np.asarray(source.lattice.low, dtype=float)
    high = low + np.asarray(source.lattice.size, dtype=float)
    for x, y, z, _ in job.sources:
        if not np.all((np.array([x, y, z]) >= low) & (np.array([x, y, z]) <= high)):
            raise InputError(f"--source {x:g},{y:g},{z:g}: the point lies outside the domain, which spans "
                             f"x {low[0]:g} to {high[0]:g} m, y {low[1]:g} to {high[1]:g} m and z {low[2]:g} "
                             f"to {high[2]:g} m.")


def _check_options(job: SandstoneJob) -> None:
    for option, value, low in (("--frames", job.frames, 1), ("--particles", job.particles, 1),
                               ("--threads", job.threads, 1), ("--substeps", job.substeps, 1),
                               ("--settle-substeps", job.settle_substeps, 1),
                               ("--snapshot-every", job.snapshot_every, 0),
                               ("--mesh-smoothing", job.mesh_smoothing, 0)):
        if value is not None and value < low:
            raise InputError(f"{option} must be at least {low}, got {value}.")
    if not (math.isfinite(job.dt) and job.dt > 0):
        raise InputError(f"--dt must be a positive number of years, got {job.dt}.")
    if not 0 <= job.seed < 2**63:
        raise InputError(f"--seed must be an integer in [0, 2^63), got {job.seed}.")
    if job.color_by not in COLOR_BY:
        raise InputError(f"--color-by must be one of {', '.join(COLOR_BY)}, got '{job.color_by}'.")
    if job.top_format not in TOP_FORMATS:
        raise InputError(f"--top-format must be tif or exr, got '{job.top_format}'.")
    if job.mesh is not None:
        try:
            mesh_format(job.mesh)
            marching_cubes_function()
        except (ValueError, MeshExtraMissing) as exc:
            raise InputError(f"--mesh: {exc}.") from None
    if job.resume and job.overwrite:
        raise InputError("--resume continues OUT_DIR's run and --overwrite starts it afresh: "
                         "give one of them.")


def _output_paths(job: SandstoneJob) -> dict[str, Path]:
    """The files of OUT_DIR, refused when one exists (without --overwrite or --resume)."""
    out = job.out_dir
    if out.exists() and not out.is_dir():
        raise InputError(f"OUT_DIR {out} is a file, not a folder.")
    if not out.parent.exists():
        raise InputError(f"the folder of OUT_DIR {out} does not exist.")
    paths = {"particles": out / PARTICLES_FILE, "top": out / f"top.{job.top_format}",
             "preview": out / PREVIEW_FILE, "frames": out / FRAMES_FILE, "run": out / RUN_FILE,
             "state": out / STATE_FILE}
    if job.mesh is not None:
        if not job.mesh.parent.exists():
            raise InputError(f"the folder of --mesh {job.mesh} does not exist.")
        paths["mesh"] = job.mesh
    if not (job.overwrite or job.resume):
        for path in [*paths.values(), out / SNAPSHOTS]:
            if path.exists():
                raise InputError(f"output {path} already exists; pass --overwrite to replace it "
                                 "(or --resume to continue its run).")
    return paths


def _source(job: SandstoneJob) -> Source:
    """The scene, preset or extruded DEM of ``job.scene``, and its lattice."""
    path = Path(job.scene)
    if job.scene in PRESETS and not path.exists():
        if job.extrude is not None:
            raise InputError("--extrude applies to a DEM, not to a preset.")
        return _scene_source(preset_scene(job.scene), f"preset {job.scene}", job)
    if not path.exists():
        raise InputError(f"SCENE {job.scene} is neither a file nor a preset ({', '.join(PRESETS)}).")
    if is_scene_file(path):
        if job.extrude is not None:
            raise InputError("--extrude applies to a DEM, not to a scene file.")
        return _scene_source(read_scene(path), str(path), job)
    if job.extrude is None:
        raise InputError(f"{path} is not a scene file (.yaml); a DEM needs --extrude BASE_M, the altitude "
                         "its rock starts from.")
    return _dem_source(path, job)


def _scene_source(scene: Scene, description: str, job: SandstoneJob) -> Source:
    size = np.asarray(scene.domain.size, dtype=float)
    try:
        lattice, expected = lattice_for(scene.shape, scene.low, size, job.particles or scene.particles,
                                        scene.cell_size)
        layers, rock = scene.layer_stack(), scene.rock_parameters()
    except ValueError as exc:
        raise InputError(f"{description}: {str(exc).rstrip('.')}.") from None
    return Source(description, layers, rock, scene.wind, lattice, expected,
                  lambda seed: scene_particles(scene, lattice, seed), water=scene.water)


def _dem_source(path: Path, job: SandstoneJob) -> Source:
    assert job.extrude is not None
    dem = read_terrain(path, band=job.band, channel=job.channel)
    dem.check_valid(path)
    base = job.extrude
    if not math.isfinite(base):
        raise InputError(f"--extrude must be a finite altitude (m), got {base}.")
    highest = float(np.nanmax(dem.elevation))
    if highest <= base:
        raise InputError(f"the DEM {path} lies at or below --extrude {base:g} m (its highest cell is "
                         f"{highest:g} m): no rock to extrude.")
    ny, nx = dem.shape
    size = np.array([nx * dem.dx, ny * dem.dy, (highest - base) * (1.0 + DEM_HEADROOM)])
    solid = ExtrudedDem(dem.elevation, (0.0, 0.0), dem.dx, dem.dy, base)
    low = np.array([0.0, 0.0, base])
    layers = LayerStack((Layer(),))
    try:
        lattice, expected = lattice_for(solid, low, size, job.particles)
    except ValueError as exc:
        raise InputError(f"{path}: {str(exc).rstrip('.')}.") from None
    return Source(f"{path} extruded from {base:g} m", layers, Rock(), Wind(), lattice, expected,
                  lambda seed: solid_particles(solid, lattice, layers, seed), dem)


def _overridden(layers: LayerStack, rock: Rock, given: dict[str, str | None]) -> tuple[LayerStack, Rock]:
    """The layers and rock with the parameters given on the command line (SI units)."""
    layer_values = {spec.name: float(text) for spec in LAYER_PARAMETERS if (text := given.get(spec.name))
    is not None}
    rock_values = {spec.name: float(text) for spec in ROCK_PARAMETERS if (text := given.get(spec.name)) is
    not None}
    return (layers.with_values(**layer_values) if layer_values else layers), replace(rock, **rock_values)


def _check_memory(source: Source) -> None:
    """Refuse, before sampling, a run that would not fit in the free memory."""
    need = memory_estimate(source.expected, source.lattice)
    free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    if need > MEMORY_SHARE * free:
        raise InputError(f"{source.description} would need about {need / 1e9:.3g} GB for "
                         f"{source.expected:.3g} particles on a {'×'.join(map(str, source.lattice.shape))} "
                         f"lattice, more than the {free / 1e9:.3g} GB of free memory: lower --particles "
                         "(or the scene's particles or cell_size).")


def _fingerprint(provenance: dict[str, Any]) -> str:
    """What a resumed run must share with the run it continues (everything but the frame count)."""
    return to_json({k: v for k, v in provenance.items() if k != "frames"})


def _resume_state(job: SandstoneJob, outputs: dict[str, Path],
                  provenance: dict[str, Any]) -> dict[str, np.ndarray]:
    state_path = outputs["state"]
    if not state_path.is_file():
        raise InputError(f"--resume needs {state_path}, written by a run with --snapshot-every; "
                         "there is none.")
    state = read_checkpoint(state_path)
    if str(state["fingerprint"]) != _fingerprint(provenance) or int(state["seed"]) != job.seed:
        raise InputError(f"the run in {job.out_dir} had other parameters or another seed; resume it with "
                         "the same scene and options (only --frames may change).")
    if int(state["frame"]) >= job.frames:
        raise InputError(f"the run in {job.out_dir} has already done {int(state['frame'])} frames; ask for "
                         "more with --frames.")
    return state


def run_job(prepared: PreparedSandstone, on_frame: Callable[[FrameStats], None] | None = None) -> str:
    """Sample (or resume), run the frames, write OUT_DIR; returns a one-line summary."""
    import numba

    job, source, outputs = prepared.job, prepared.source, prepared.outputs
    if job.threads is not None:
        numba.set_num_threads(min(job.threads, numba.config.NUMBA_NUM_THREADS))
    job.out_dir.mkdir(exist_ok=True)
    if job.snapshot_every:
        (job.out_dir / SNAPSHOTS).mkdir(exist_ok=True)
    for path in outputs.values():
        check_output(path, True)
    start = time.perf_counter()
    rows: list[dict[str, Any]] = []
    if prepared.resume_state is not None:
        state = prepared.resume_state
        particles = Particles.from_arrays({k[len("particle_"):]: v for k, v in state.items()
                                           if k.startswith("particle_")})
        rows = json.loads(str(state["rows"]))
        simulation = Simulation(particles, source.layers, source.rock, source.lattice, prepared.params,
                                job.seed, int(state["frame"]))
        simulation.changes = state["changes"]
    else:
        particles = source.build(job.seed)
        if len(particles) == 0:
            raise InputError(f"{source.description} has no particle inside the domain.")
        simulation = Simulation(particles, source.layers, source.rock, source.lattice, prepared.params,
                                job.seed)
    sampled = time.perf_counter() - start
    while simulation.frame < job.frames:
        stats = simulation.step()
        rows.append(_row(stats))
        if on_frame is not None:
            on_frame(stats)
        if job.snapshot_every and stats.frame % job.snapshot_every == 0:
            _snapshot(prepared, simulation, rows)
    seconds = time.perf_counter() - start
    _write_outputs(prepared, simulation, rows, seconds, sampled)
    final = simulation.particles
    removed = sum(r["eroded"] for r in rows)
    return (f"{COMMAND}: {source.description}, {len(final):,} particles after {simulation.frame} frames "
            f"({removed:,} eroded, {sum(r['exported'] for r in rows):,} exported; "
            f"{float(final.interlocked.mean()) if len(final) else 0.0:.1%} interlocked) in {seconds:.1f} s; "
            f"wrote {job.out_dir}")


def _row(stats: FrameStats) -> dict[str, Any]:
    row = {k: getattr(stats, k) for k in FRAME_COLUMNS[:7]}
    row.update(max_stress_mpa=stats.max_stress / 1e6, mpm_substeps=stats.mpm_substeps,
               mpm_residual=stats.mpm_residual, eroded_fluvial=stats.eroded_fluvial,
               discharge_max_m3y=stats.discharge_max, **{f"{s}_s": stats.seconds[s] for s in STAGES})
    return row


def _ply(path: Path, prepared: PreparedSandstone, simulation: Simulation) -> None:
    p = simulation.particles
    rate = np.where(p.interlocked, simulation.k_s[p.layer], simulation.k_w[p.layer]) * p.erodibility
    write_particle_ply(path, p.positions, p.normals, {
        "viability": p.viability, "stress": p.stress / 1e6, "erodibility": rate, "layer": p.layer,
        "surface": surface_particles(p.positions, simulation.surface_grid), "deposit": p.deposit,
        "interlocked": p.interlocked, "vegetation": p.vegetation,
    }, comments=(f"unerode-cli {COMMAND}: {prepared.source.description}, frame {simulation.frame}",
                 "stress: -tr(sigma) in MPa (compression positive); erodibility: E in 1/y (002 Eq. 2)"))


def _snapshot(prepared: PreparedSandstone, simulation: Simulation, rows: list[dict[str, Any]]) -> None:
    folder = prepared.job.out_dir / SNAPSHOTS
    path = folder / f"frame_{simulation.frame:05d}.ply"
    check_output(path, True)
    _ply(path, prepared, simulation)
    arrays = {f"particle_{k}": v for k, v in simulation.particles.arrays().items()}
    write_checkpoint(prepared.outputs["state"], **arrays, frame=simulation.frame, seed=prepared.job.seed,
                     rows=to_json(rows), changes=simulation.changes,
                     fingerprint=_fingerprint(prepared.provenance))


def _write_outputs(prepared: PreparedSandstone, simulation: Simulation, rows: list[dict[str, Any]],
                   seconds: float, sampled: float) -> None:
    job, source, outputs = prepared.job, prepared.source, prepared.outputs
    p = simulation.particles
    _ply(outputs["particles"], prepared, simulation)
    mesh = _mesh(prepared, simulation) if job.mesh is not None else None
    entry = history_entry(COMMAND, prepared.provenance, job.seed)
    top = _top(source, p)
    append_history(top, entry)
    write_terrain(top, outputs["top"])
    values = {"layer": p.layer, "stress": p.stress / 1e6, "viability": p.viability}[job.color_by]
    label = {"layer": "layer (bottom = 0; the last is deposits)", "stress": "-tr σ (MPa)",
             "viability": "viability b"}[job.color_by]
    with atomic_path(outputs["preview"]) as tmp:
        save_particles_preview(p.positions, p.normals, values, tmp, label, source.lattice.spacing,
                               title=f"{source.description}, frame {simulation.frame}",
                               categorical=job.color_by == "layer")
    write_table(outputs["frames"], FRAME_COLUMNS, rows)
    import numba
    import scipy

    versions = {"numpy": np.__version__, "numba": numba.__version__, "scipy": scipy.__version__,
                **io_library_versions()}
    statistics = {
        "particles": len(p), "frames": simulation.frame,
        **{key: sum(r[key] for r in rows) for key in ("eroded", "deposited", "exported", "eroded_fluvial")},
        "discharge_max_m3y": max((r["discharge_max_m3y"] for r in rows), default=0.0),
        "interlocked_share": float(p.interlocked.mean()) if len(p) else 0.0,
        "wall_time_s": seconds, "sampling_s": sampled,
        "stage_seconds": {stage: sum(r[f"{stage}_s"] for r in rows) for stage in STAGES},
        **({"mesh": mesh} if mesh is not None else {}),
    }
    write_json(outputs["run"], {**entry, "versions": versions, "threads": numba.get_num_threads(),
                                "statistics": statistics})


def _mesh(prepared: PreparedSandstone, simulation: Simulation) -> dict[str, Any]:
    """Write the surface mesh of the final particles (each a lattice cell of rock, on the
    domain's floor as the ground); its vertex and face counts, enclosed volume (m³) and time. For
    an extruded DEM whose CRS is in metres, the header gives its south-west corner as the origin."""
    job, source = prepared.job, prepared.source
    start = time.perf_counter()
    p, lattice = simulation.particles, source.lattice
    mesh = particle_mesh(p.positions, p.layer, lattice.spacing**3, lattice.spacing, job.mesh_smoothing,
                         ground=lattice.low[2])
    origin, crs_wkt = (0.0, 0.0, 0.0), None
    dem = source.dem
    if dem is not None and math.isclose(dem.transform.a, dem.dx) and math.isclose(-dem.transform.e, dem.dy):
        west, south = dem.transform * (0, dem.shape[0])
        origin, crs_wkt = (west, south, 0.0), dem.crs_wkt or None
    write_mesh(prepared.outputs["mesh"], mesh, overwrite=True, origin=origin, crs_wkt=crs_wkt,
               comments=(f"unerode-cli {COMMAND}: {source.description}, frame {simulation.frame}",
                         "vertex colour: the layer's, as in preview.png; material: the layer (bottom = 0, "
                         "the last is deposits)"))
    return {"file": str(job.mesh), "vertices": len(mesh.vertices), "faces": len(mesh.faces),
            "enclosed_volume_m3": enclosed_volume(mesh), "particle_volume_m3": len(p) * lattice.spacing**3,
            "smoothing_iterations": job.mesh_smoothing, "seconds": time.perf_counter() - start}


def _top(source: Source, particles: Particles) -> Terrain:
    """The top heightfield: on the DEM's grid (and CRS) for an extruded DEM, else on the
    lattice's columns with a local (CRS-less) transform."""
    lattice = source.lattice
    if source.dem is not None:
        dem = source.dem
        top = top_surface(particles.positions, (0.0, 0.0), dem.dx, dem.dy, dem.shape, lattice.low[2],
                          lattice.spacing)
        return dem.with_elevation(top)
    nx, ny = lattice.shape[0], lattice.shape[1]
    s = lattice.spacing
    top = top_surface(particles.positions, lattice.low[:2], s, s, (ny, nx), lattice.low[2], s)
    transform = Affine(s, 0.0, lattice.low[0], 0.0, -s, lattice.low[1] + ny * s)
    return Terrain(top, s, s, transform=transform)
