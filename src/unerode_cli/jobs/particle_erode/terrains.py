"""The terrains a `particle-erode` job alters, built from its inputs: a layered terrain (003
§4.2) under the DEM, voxels (003 §4.4: a block built from the DEM by ``volume.dem_block``, or
the volume of ``--voxels``, with 3D material layers) and implicit terrains (003 §4.3: the DEM's
surface or the scene of ``--sdf``, on the nodes of the block the DEM would give)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import read_bands_on_grid
from unerode_cli.io.material_files import read_materials
from unerode_cli.io.sdf_scene import read_sdf_scene
from unerode_cli.io.terrain import Terrain
from unerode_cli.io.voxel_files import (
    MaterialLayers,
    VoxelFile,
    read_material_layers,
    read_voxels,
    voxel_file_layout,
)
from unerode_cli.jobs.particle_erode import parsers
from unerode_cli.jobs.particle_erode.checks import bad_input
from unerode_cli.particles import (
    IMPLICIT_REPRESENTATIONS,
    BinaryTerrain,
    DensityTerrain,
    LayeredTerrain,
    Material,
    MaterialRules,
    SdfTerrain,
    run_bytes,
    sdf_run_bytes,
)
from unerode_cli.volume import dem_block
from unerode_cli.volume.voxels import BinaryVoxels, DensityVoxels, VoxelGeometry, horizon_material


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


def layered_terrain(job: Any, dem: Terrain, notes: list[str]) -> LayeredTerrain:
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
        chosen = parsers.material_names(job.layer_materials)
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
                         f"more than the {budget_gib:g} GiB of --memory-budget; use larger voxels or a "
                         "smaller area, or raise --memory-budget.")


def _voxel_materials(job: Any, notes: list[str]) -> tuple[list[Material] | None, MaterialLayers | None]:
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


def block_frame(job: Any, dem: Terrain, representation: str, with_material: bool,
                extent: tuple[float, float] | None = None) -> dem_block.BlockFrame:
    """The block under the DEM (``volume.dem_block``: --voxel-size, --depth, --headroom, the
    elevations ``extent`` included), its run's memory checked against --memory-budget."""
    if not (math.isclose(dem.transform.a, dem.dx, rel_tol=1e-6)
            and math.isclose(-dem.transform.e, dem.dy, rel_tol=1e-6)):
        raise InputError(f"{job.source} is not in a projected CRS in metres; a voxel block needs one "
                         "(reproject it, e.g. gdalwarp -t_srs EPSG:32632).")
    with bad_input():
        geometry = dem_block.geometry_under(dem.elevation, dem.dx, dem.dy, dem.transform.c, dem.transform.f,
                                            job.voxel_size, job.depth, job.headroom, extent)
    _check_memory(geometry.count, representation, with_material, job.memory_budget,
                  f"the block of {geometry.size[2]:g} m voxels under {job.source.name}")
    return dem_block.frame(geometry, dem.elevation, dem.grid.valid, dem.dx, dem.dy)


def _from_file(job: Any, representation: str, materials: list[Material] | None,
               layers: MaterialLayers | None) -> tuple[DensityVoxels | BinaryVoxels, VoxelFile]:
    """The volume of --voxels as ``representation``, its material indices those of ``materials``."""
    assert job.voxels is not None
    shape, _, has_material = voxel_file_layout(job.voxels)
    _check_memory(shape[0] * shape[1] * shape[2], representation, has_material or materials is not None,
                  job.memory_budget, f"the voxel file {job.voxels.name}")
    file = read_voxels(job.voxels)
    voxels = dem_block.as_kind(file.voxels, representation)
    if voxels.material is None:
        return voxels, file
    if materials is None:
        raise InputError(f"the voxel file {job.voxels} has a material index: give the materials' "
                         "erodibilities with --materials.")
    if layers is not None and layers.tops:
        raise InputError(f"the voxel file {job.voxels} has its own material index; --materials gives "
                         "horizons, which are for a block built from the DEM.")
    if file.material_names:
        lookup = np.array([_material_index(name, materials, job.materials) for name in file.material_names],
                          dtype=np.int16)
        voxels.material = lookup[voxels.material]
    elif int(voxels.material.max()) >= len(materials):
        raise InputError(f"the voxel file {job.voxels} uses material index {int(voxels.material.max())}, and "
                         f"the materials table {job.materials} has {len(materials)} material(s).")
    return voxels, file


def _material_rules(job: Any, materials: list[Material] | None, layers: MaterialLayers | None,
                    from_file: bool) -> MaterialRules:
    """What deposits become (--deposit-material, the layers' deposit, else the top horizon's
    material for a block) and what eroded materials become (the layers' rules)."""
    if materials is None:
        return MaterialRules()
    deposit = layers.deposit if layers is not None else None
    if job.deposit_material:
        deposit = _material_index(job.deposit_material, materials, job.materials)
    elif deposit is None and layers is not None and layers.horizon_materials and not from_file:
        deposit = layers.horizon_materials[-1]
    return MaterialRules(-1 if deposit is None else deposit, dict(layers.eroded) if layers else {})


def voxel_setup(job: Any, dem: Terrain, representation: str, notes: list[str]) -> VoxelSetup:
    """The voxel terrain (003 §4.4) of the job: --voxels' volume, or a block built from the DEM;
    its materials and material rules from --materials and --deposit-material."""
    materials, layers = _voxel_materials(job, notes)
    if job.voxels is not None:
        voxels, file = _from_file(job, representation, materials, layers)
        crs_wkt = file.crs_wkt or dem.crs_wkt
        description = f"the volume {job.voxels.name}"
    else:
        voxels = dem_block.filled_block(block_frame(job, dem, representation, materials is not None),
                                        representation)
        crs_wkt = dem.crs_wkt
        description = f"a block under {job.source.name}"
    if materials is not None and voxels.material is None:
        if layers is None or not layers.tops:
            raise InputError(f"the materials {job.materials} give no horizons to place in the volume: use a "
                             "YAML of 3D material layers with 'horizons' (or a voxel file with a material "
                             "index).")
        voxels.material = horizon_material(voxels.geometry, np.array(layers.tops),
                                           np.array(layers.horizon_materials))
    rules = _material_rules(job, materials, layers, job.voxels is not None)
    names = tuple(m.name for m in materials) if materials is not None else ()
    with bad_input():
        if representation == "density":
            terrain: DensityTerrain | BinaryTerrain = DensityTerrain(voxels, materials, rules)
        else:
            binary = {"alpha": job.hits_per_voxel, "threshold": job.hits_threshold}
            given = {k: v for k, v in binary.items() if v is not None}
            terrain = BinaryTerrain(voxels, materials, rules, **given)
    return VoxelSetup(terrain, surface_raster(terrain, crs_wkt, dem), crs_wkt, names, description)


def sdf_setup(job: Any, dem: Terrain) -> VoxelSetup:
    """The implicit terrain (003 §4.3) of the job: the DEM's surface, or the scene of --sdf in
    the DEM's CRS, on the nodes of the block the DEM would give (--voxel-size, --depth,
    --headroom, reaching the scene's shapes)."""
    from unerode_cli.volume.sdf_field import ImplicitField
    from unerode_cli.volume.sdf_shapes import Surface, uses_surface

    scene = read_sdf_scene(job.sdf) if job.sdf is not None else Surface()
    block = block_frame(job, dem, "sdf", False, scene.z_range())
    dx, dy, _ = block.geometry.size
    west, north, _ = block.geometry.origin
    with bad_input():
        field = ImplicitField(block.geometry, scene.framed(west + 0.5 * dx, north - 0.5 * dy),
                              block.heights if uses_surface(scene) else None)
        terrain = SdfTerrain(field, block.columns)
    description = (f"the scene {job.sdf.name} over {job.source.name}" if job.sdf is not None
                   else f"the surface of {job.source.name}")
    return VoxelSetup(terrain, surface_raster(terrain, dem.crs_wkt, dem), dem.crs_wkt, (), description)


def geometry_of(terrain: DensityTerrain | BinaryTerrain | SdfTerrain) -> VoxelGeometry:
    """The voxels of a 3D terrain (an implicit one's cache nodes)."""
    return terrain.geometry if isinstance(terrain, SdfTerrain) else terrain.voxels.geometry


def surface_raster(terrain: DensityTerrain | BinaryTerrain | SdfTerrain, crs_wkt: str,
                   dem: Terrain) -> Terrain:
    """The top heightfield of a 3D terrain as a raster on its columns (NaN outside the
    domain), with the DEM's nodata value and tags."""
    geometry = geometry_of(terrain)
    dx, dy, _ = geometry.size
    west, north, _ = geometry.origin
    elevation = np.where(terrain.grid.valid, terrain.surface(), np.nan)
    transform = Affine(dx, 0.0, west, 0.0, -dy, north)
    return Terrain(elevation, dx, dy, crs_wkt, transform, dem.nodata, dict(dem.tags))


def volume_provenance(volume: VoxelSetup) -> dict[str, Any]:
    """What the history records of a 3D terrain: what it was built from, its voxels (m), its
    materials and rules, and the hit counts of binary voxels."""
    terrain = volume.terrain
    geometry = geometry_of(terrain)
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
