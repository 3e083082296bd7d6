"""What a `sandstone` job writes in OUT_DIR (through ``io/`` and ``viz/``, atomically):
``particles.ply`` (and the snapshots of ``--snapshot-every``), the top heightfield,
``preview.png``, ``frames.csv``, ``run.json`` and the ``--mesh`` surface. The run's state
(``state.npz``) is the stepping loop's checkpoint (``jobs/sandstone/frames.py``)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine

from unerode_cli.io.csv_tables import write_table
from unerode_cli.io.json_files import write_json
from unerode_cli.io.mesh_files import write_mesh
from unerode_cli.io.particle_ply import write_particle_ply
from unerode_cli.io.paths import atomic_path
from unerode_cli.io.provenance import append_history, history_entry
from unerode_cli.io.rasters import write_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.versions import io_library_versions
from unerode_cli.jobs.sandstone.planning import PreparedSandstone
from unerode_cli.jobs.sandstone.source import Source
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.sampling import top_surface
from unerode_cli.sandstone.simulation import STAGES, FrameStats, Simulation
from unerode_cli.sandstone.surface import near_changes, normals, surface_particles
from unerode_cli.viz.particles_preview import save_particles_preview
from unerode_cli.volume.mesh import enclosed_volume, material_colours
from unerode_cli.volume.particle_surface import particle_mesh
from unerode_cli.volume.vertex_attributes import vertex_values

COMMAND = "sandstone"
FRAME_COLUMNS = ["frame", "particles", "eroded", "deposited", "exported", "surface", "interlocked_share",
                 "max_stress_mpa", "mpm_substeps", "mpm_residual", "mpm_coarse_cost", "eroded_fluvial",
                 "discharge_max_m3y",
                 "fallen", *(f"{s}_s" for s in STAGES)]
#: Colour of preview.png per ``--color-by``: the caption of its values.
PREVIEW_LABELS = {"layer": "layer (bottom = 0; the last is deposits)", "stress": "-tr σ (MPa)",
                  "viability": "viability b"}


def row(stats: FrameStats) -> dict[str, Any]:
    """One row of ``frames.csv``: a frame's counts, stress (MPa), solver and stage times (s)."""
    values = {k: getattr(stats, k) for k in FRAME_COLUMNS[:7]}
    values.update(max_stress_mpa=stats.max_stress / 1e6, mpm_substeps=stats.mpm_substeps,
                  mpm_residual=stats.mpm_residual, mpm_coarse_cost=stats.mpm_coarse_cost,
                  eroded_fluvial=stats.eroded_fluvial,
                  discharge_max_m3y=stats.discharge_max, fallen=stats.fallen,
                  **{f"{s}_s": stats.seconds[s] for s in STAGES})
    return values


def write_particles(path: Path, prepared: PreparedSandstone, simulation: Simulation,
                    surface: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """The particles as a binary PLY: position and normal, viability, stress −tr σ (MPa),
    erodibility E (1/y, 002 Eq. 2), layer, surface, deposit, interlocked, vegetation;
    ``surface``: :func:`final_surface` of the simulation when already known."""
    p = simulation.particles
    rate = np.where(p.interlocked, simulation.k_s[p.layer], simulation.k_w[p.layer]) * p.erodibility
    surface, normal = surface if surface is not None else final_surface(simulation)
    write_particle_ply(path, p.positions, normal, {
        "viability": p.viability, "stress": p.stress / 1e6, "erodibility": rate, "layer": p.layer,
        "surface": surface, "deposit": p.deposit, "interlocked": p.interlocked, "vegetation": p.vegetation,
    }, colours=material_colours(p.layer),
        comments=(f"unerode-cli {COMMAND}: {prepared.source.description}, frame {simulation.frame}",
                  "stress: -tr(sigma) in MPa (compression positive); erodibility: E in 1/y (002 Eq. 2)",
                  "red green blue: the layer's colour, as in preview.png and the --mesh"))


def final_surface(simulation: Simulation) -> tuple[np.ndarray, np.ndarray]:
    """The surface flags ``(N,)`` and unit outward normals ``(N, 3)`` (zeros off the surface) of
    the particles as the last frame left them: its erosion and deposition changed the surface
    that its normals were computed on (002 Alg. 1 computes them before eroding), so the normals
    are recomputed near its changes, as the next frame's will be; the simulation is unchanged."""
    p, grid = simulation.particles, simulation.surface_grid
    surface = surface_particles(p.positions, grid)
    return surface, normals(p.positions, surface, grid, simulation.params.neighbours, previous=p.normals,
                            recompute=near_changes(p.positions, simulation.changes, grid))


def write_outputs(prepared: PreparedSandstone, simulation: Simulation, rows: list[dict[str, Any]],
                  seconds: float, sampled: float) -> None:
    """Every file of OUT_DIR (and ``--mesh``); ``seconds``: the run's wall time, ``sampled``: that
    of the sampling (s)."""
    job, source, paths = prepared.job, prepared.source, prepared.paths
    p = simulation.particles
    surface = final_surface(simulation)
    write_particles(paths["particles"], prepared, simulation, surface)
    mesh = write_particle_mesh(paths["mesh"], prepared, simulation) if job.mesh is not None else None
    entry = history_entry(COMMAND, prepared.provenance, job.seed)
    top = _top(source, p)
    append_history(top, entry)
    write_terrain(top, paths["top"])
    values = {"layer": p.layer, "stress": p.stress / 1e6, "viability": p.viability}[job.color_by]
    with atomic_path(paths["preview"]) as tmp:
        save_particles_preview(p.positions, surface[1], values, tmp, PREVIEW_LABELS[job.color_by],
                               source.lattice.spacing, categorical=job.color_by == "layer",
                               title=f"{source.description}, frame {simulation.frame}")
    write_table(paths["frames"], FRAME_COLUMNS, rows)
    import numba
    import scipy

    versions = {"numpy": np.__version__, "numba": numba.__version__, "scipy": scipy.__version__,
                **io_library_versions()}
    statistics = {
        "particles": len(p), "frames": simulation.frame,
        **{key: sum(r[key] for r in rows) for key in ("eroded", "deposited", "exported", "eroded_fluvial",
                                                           "fallen")},
        "discharge_max_m3y": max((r["discharge_max_m3y"] for r in rows), default=0.0),
        "interlocked_share": float(p.interlocked.mean()) if len(p) else 0.0,
        "wall_time_s": seconds, "sampling_s": sampled,
        "stage_seconds": {stage: sum(r[f"{stage}_s"] for r in rows) for stage in STAGES},
        **({"mesh": mesh} if mesh is not None else {}),
    }
    write_json(paths["run"], {**entry, "versions": versions, "threads": numba.get_num_threads(),
                              "statistics": statistics})


def material_names(prepared: PreparedSandstone) -> list[str]:
    """The mesh's material name of each layer index: the layer's name, else ``layer_<i>``; the
    deposit layer (the last) is ``deposits``."""
    layers = prepared.source.layers
    return [layer.name or f"layer_{i}" for i, layer in enumerate(layers.layers)] + ["deposits"]


def write_particle_mesh(path: Path, prepared: PreparedSandstone, simulation: Simulation) -> dict[str, Any]:
    """Write the surface mesh of the particles at ``path`` (.glb, .obj with its .mtl, or .ply;
    ``--up`` axes; one material per layer; per-vertex stress (MPa), viability and layer of the
    nearest particle), meshed at ``--mesh-cell`` (m, default the particle spacing) on the
    domain's floor as the ground. For an extruded DEM whose CRS is in metres, the file's origin
    is the DEM's south-west corner. Returns its vertex and face counts, enclosed volume (m³) and
    the seconds it took."""
    job, source = prepared.job, prepared.source
    start = time.perf_counter()
    p, lattice = simulation.particles, source.lattice
    cell = job.mesh_cell if job.mesh_cell is not None else lattice.spacing
    mesh = particle_mesh(p.positions, p.layer, lattice.spacing**3, cell, job.mesh_smoothing,
                         ground=lattice.low[2])
    values = {"stress": p.stress / 1e6, "viability": p.viability, "layer": p.layer}
    attributes = vertex_values(mesh.vertices, p.positions, values) if len(p) else {}
    origin, crs_wkt = (0.0, 0.0, 0.0), None
    dem = source.dem
    if dem is not None and math.isclose(dem.transform.a, dem.dx) and math.isclose(-dem.transform.e, dem.dy):
        west, south = dem.transform * (0, dem.shape[0])
        origin, crs_wkt = (west, south, 0.0), dem.crs_wkt or None
    write_mesh(path, mesh, overwrite=True, origin=origin, crs_wkt=crs_wkt, up=job.up,
               material_names=material_names(prepared), attributes=attributes,
               comments=(f"unerode-cli {COMMAND}: {source.description}, frame {simulation.frame}",
                         "material: the layer (bottom = 0, the last is deposits); stress: -tr(sigma) in MPa"))
    return {"file": str(path), "vertices": len(mesh.vertices), "faces": len(mesh.faces),
            "enclosed_volume_m3": enclosed_volume(mesh), "particle_volume_m3": len(p) * lattice.spacing**3,
            "cell_m": cell, "smoothing_iterations": job.mesh_smoothing, "up": job.up,
            "seconds": time.perf_counter() - start}


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
