"""The statistics and the outputs of a `particle-erode` run, written through ``io``: the new
surface (its history and JSON sidecar holding the mass budget and counts), the change map, the
layers of a layered terrain, the altered volume and its surface mesh (and the mesh's rendered
preview) of a 3D terrain, and the sampled particle paths."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from unerode_cli.io.grid_rasters import write_bands
from unerode_cli.io.json_files import to_json
from unerode_cli.io.mesh_files import write_mesh
from unerode_cli.io.particle_paths import write_paths
from unerode_cli.io.paths import atomic_path
from unerode_cli.io.provenance import history_entry, write_sidecar
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.voxel_files import VoxelFile, write_voxels
from unerode_cli.particles import BinaryTerrain, DensityTerrain, LayeredTerrain, ParticleRun, SdfTerrain
from unerode_cli.particles import Terrain as ParticleTerrain
from unerode_cli.run.outputs import Outputs, field_preview, save
from unerode_cli.run.stepping import finish_checkpoints
from unerode_cli.viz.particles_preview import save_particles_preview
from unerode_cli.volume.mesh import MeshExtraMissing, enclosed_volume, marching_cubes_function, vertex_normals
from unerode_cli.volume.voxels import ground_mesh

if TYPE_CHECKING:
    from unerode_cli.jobs.particle_erode.job import ParticleResult, PreparedParticleJob

COMMAND = "particle-erode"

MASS_BUDGET_NOTE = (
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
    "where particles died.")


def change_preview_path(change_map: Path) -> Path:
    """``dh.tif`` → ``dh.png``: the change map's preview, written when --preview is given."""
    return change_map.with_suffix(".png")


def default_layers_path(output: Path) -> Path:
    """``OUT.tif`` → ``OUT_layers.tif`` (always a GeoTIFF: layers are multi-band)."""
    return output.with_name(f"{output.stem}_layers.tif")


def _extra_statistics(result: ParticleRun, terrain: ParticleTerrain) -> dict[str, Any]:
    """The hits of binary voxels, and the budget and counts of each kind when there are several."""
    extra: dict[str, Any] = {}
    if isinstance(result.terrain, BinaryTerrain) and isinstance(terrain, BinaryTerrain):
        extra["binary_voxels"] = dict(zip(
            ("erosion_hits", "deposition_hits", "voxels_removed", "voxels_added", "voxels_transformed",
             "unplaced_hits"), (int(v) for v in result.terrain.counters), strict=True))
        extra["binary_voxels"]["hits_held_change"] = int(
            result.terrain.voxels.hits.sum(dtype=np.int64) - terrain.voxels.hits.sum(dtype=np.int64))
    if len(result.kinds) > 1:
        extra["kinds"] = [{"kind": k.name, "particles": k.stats.particles, "impacts": k.stats.impacts,
                           "detached_m3": k.budget.detached, "deposited_m3": k.budget.deposited,
                           "lost_at_edges_m3": k.budget.lost, "suspended_m3": k.budget.suspended,
                           "emitted_m3": k.budget.emitted} for k in result.kinds]
    return extra


def statistics(result: ParticleRun, dem: Terrain, seconds: float, terrain: ParticleTerrain) -> dict[str, Any]:
    """Run statistics for the sidecar: mass budget (m³), counts, Δh (m) and speed; on 3D terrains
    the change of the volume's matter, what left the grid and the hits of binary voxels; with
    several kinds of particles the budget and counts of each."""
    b = result.budget
    scale = b.detached + b.emitted
    dh = result.dh[dem.grid.valid]
    change = math.fsum(dh) * dem.dx * dem.dy
    extra: dict[str, Any] = {}
    if isinstance(result.terrain, DensityTerrain | BinaryTerrain | SdfTerrain):
        change = result.terrain.matter() - terrain.matter()
        extra["top_surface_volume_change"] = math.fsum(dh) * dem.dx * dem.dy
    if isinstance(result.terrain, DensityTerrain):
        extra["left_grid"] = result.terrain.left
    return {
        "mass_budget_m3": {
            "detached": b.detached, "deposited": b.deposited, "suspended": b.suspended,
            "lost_at_edges": b.lost, "emitted": b.emitted, "dropped": b.dropped,
            "residual": b.residual, "relative_residual": abs(b.residual) / scale if scale > 0 else 0.0,
            "terrain_volume_change": change, **extra,
        },
        **_extra_statistics(result, terrain),
        "mass_budget_note": MASS_BUDGET_NOTE,
        "particles": result.stats.particles, "impacts": result.stats.impacts,
        "settled": result.stats.settled, "left_domain": result.stats.lost, "expired": result.stats.expired,
        "mean_abs_change_m": float(np.abs(dh).mean()), "max_erosion_m": float(max(0.0, -dh.min())),
        "max_deposition_m": float(max(0.0, dh.max())), "wall_time_s": seconds,
        "particles_per_second": result.stats.particles / seconds if seconds > 0 else None,
    }


def meshes_available() -> bool:
    """Whether surface meshes can be made (scikit-image is installed)."""
    try:
        marching_cubes_function()
    except MeshExtraMissing:
        return False
    return True


def write_all(prepared: PreparedParticleJob, result: ParticleResult) -> str:
    """Write every output of a finished run, remove its checkpoint, and return the one-line
    summary. A run stopped before its end (--max-steps, cancelled) writes nothing more than its
    checkpoint and says how to go on."""
    job, dem, run = prepared.job, prepared.surface, result.run
    if not result.stepped.finished:
        return (f"{COMMAND}: stopped after iteration {result.stepped.done} of {prepared.iterations}; "
                "run again with --resume to continue.")
    stats = result.statistics
    outputs = prepared.outputs
    mesh_preview = prepared.volume is not None and outputs.preview is not None and meshes_available()
    if prepared.volume is not None:
        _write_volume(run, prepared, stats, mesh_preview)
    save(dem.with_elevation(run.elevation), outputs, COMMAND, prepared.provenance, stats, seed=job.seed,
         elevation_preview=not mesh_preview)
    if job.change_map is not None:
        save(dem.with_elevation(run.dh), Outputs(job.change_map, outputs.options, outputs.overwrite),
             COMMAND + " change", prepared.provenance, stats, seed=job.seed, elevation_preview=False)
        if outputs.preview is not None:
            field_preview(run.dh, dem, change_preview_path(job.change_map), "Δh (m)",
                          title=job.change_map.name, diverging=True)
    if prepared.layers_out is not None:
        _write_layers(run, prepared, stats)
    per_iteration = prepared.provenance["particles_per_iteration"]
    if job.paths is not None:
        write_paths(job.paths, run.paths, dem, per_iteration)
    finish_checkpoints(prepared.checkpoints, result.stepped)
    b = run.budget
    return (f"{COMMAND}: {prepared.provenance['preset']} preset on {prepared.provenance['representation']}, "
            f"{run.stats.particles} particles "
            f"({run.iterations} × {per_iteration}), {run.stats.impacts} impacts in "
            f"{result.seconds:.2f} s; detached {b.detached:.4g} m³, deposited {b.deposited:.4g} m³, lost at "
            f"edges {b.lost:.4g} m³, suspended {b.suspended:.4g} m³, emitted {b.emitted:.4g} m³ "
            f"(residual {stats['mass_budget_m3']['relative_residual']:.1e}); wrote {outputs.path}")


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
    """The layers of a layered terrain (thicknesses m, bottom first, the deposit layer on top,
    band descriptions the materials) with their history and sidecar."""
    terrain = result.terrain
    assert isinstance(terrain, LayeredTerrain) and prepared.layers_out is not None
    names = [terrain.materials[m].name for m in terrain.layer_material]
    entry = history_entry(COMMAND + " layers", prepared.provenance, prepared.job.seed)
    tags = {"UNERODE_HISTORY": to_json([entry]), "UNERODE_LAYERS": "thickness (m), bottom layer first",
            "UNERODE_DEPOSIT_MATERIAL": names[-1]}
    write_bands(terrain.thickness, prepared.dem, prepared.layers_out, prepared.outputs.options, names, tags)
    write_sidecar(prepared.layers_out, entry, {**stats, "layer_materials": names})
