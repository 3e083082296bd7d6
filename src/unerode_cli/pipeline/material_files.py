"""Files of layered terrains (003 §4.2) and of other multi-band rasters on a DEM's grid.

- Materials table: CSV with a header row; columns ``name``, ``erodibility`` (K_ε of 003
  Eq. 2, Pa^-a, ≥ 0) and optionally ``critical_stress`` (τ_c of 003 Eq. 2, Pa, ≥ 0; empty or
  absent = 0) and ``description``, in any order; lines starting with ``#`` are comments. It is
  read like the observation tables (same rules, errors naming the line).
- Layers raster: one band per layer, thicknesses in metres, bottom layer first (band 1). Band
  descriptions may name each layer's material.
- Multi-band rasters (layers, a velocity field) are read whole and checked against the DEM's
  grid (shape, transform, CRS), like ``parameter_maps.read_on_grid`` does for one band.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rasterio
from rasterio.crs import CRS as RioCRS
from rasterio.errors import RasterioIOError

from unerode_cli.errors import InputError
from unerode_cli.particles.terrain import Material
from unerode_cli.pipeline.csv_tables import table_number, table_rows
from unerode_cli.pipeline.outputs import Outputs
from unerode_cli.pipeline.parameter_maps import same_crs
from unerode_cli.raster.gdal_io import COG_DEFAULTS, GTIFF_DEFAULTS
from unerode_cli.raster.paths import atomic_path
from unerode_cli.raster.terrain import Terrain

MATERIAL_COLUMNS = ("name", "erodibility", "critical_stress", "description")
MATERIAL_REQUIRED = ("name", "erodibility")


def read_materials(path: Path) -> list[Material]:
    """The materials of a CSV table (module docstring), in file order.

    Raises:
        InputError: unreadable file, unknown or missing column, or a bad row (the message
            names its line).
    """
    materials: list[Material] = []
    for line, row in table_rows(path, "materials", MATERIAL_COLUMNS, MATERIAL_REQUIRED):
        if any(m.name == row["name"] for m in materials):
            raise InputError(f"{path}, line {line}: material '{row['name']}' is named twice.")
        materials.append(Material(row["name"], table_number(row, "erodibility", path, line, minimum=0.0),
                                  table_number(row, "critical_stress", path, line, minimum=0.0) or 0.0))
    if not materials:
        raise InputError(f"the materials table {path} lists no material.")
    return materials


@dataclass(frozen=True)
class Bands:
    """A multi-band raster on a DEM's grid: float64[bands, ny, nx] values (NaN where the file
    has nodata) and each band's description ("" when none)."""

    values: np.ndarray
    descriptions: tuple[str, ...]


def read_bands_on_grid(path: Path, terrain: Terrain, what: str) -> Bands:
    """Read every band of a raster that must lie on ``terrain``'s grid (shape, transform and
    CRS checked; ``what`` names it in messages)."""
    if not Path(path).is_file():
        raise InputError(f"{what} raster {path} does not exist.")
    try:
        src = rasterio.open(path)
    except RasterioIOError:
        raise InputError(f"{what} file {path} is not a raster that GDAL can read.") from None
    with src:
        if src.shape != terrain.shape:
            raise InputError(f"{what} raster {path} has {src.shape[0]} × {src.shape[1]} cells but the "
                             f"DEM has {terrain.shape[0]} × {terrain.shape[1]}.")
        if not src.transform.almost_equals(terrain.transform, precision=1e-9 * max(terrain.dx, 1)):
            raise InputError(f"{what} raster {path} is not aligned with the DEM (different transform).")
        if not same_crs(src.crs.to_wkt() if src.crs else "", terrain.crs_wkt):
            raise InputError(f"{what} raster {path} is not in the DEM's CRS.")
        values = src.read().astype(np.float64)
        valid = src.read_masks() > 0
        descriptions = tuple(d or "" for d in src.descriptions)
    values[~valid] = np.nan
    return Bands(values, descriptions)


def write_bands(values: np.ndarray, terrain: Terrain, outputs: Outputs, descriptions: list[str],
                tags: dict[str, Any]) -> None:
    """Write float[bands, ny, nx] on ``terrain``'s grid as a multi-band GeoTIFF (or COG),
    atomically; nodata cells of the terrain are written as nodata (−9999, or NaN should a
    value equal it). Band descriptions and dataset ``tags`` are kept; units are metres."""
    if outputs.path.suffix.lower() not in (".tif", ".tiff"):
        raise InputError(f"a multi-band output must be a GeoTIFF (.tif), got {outputs.path.name}.")
    dtype = outputs.options.dtype
    mask = terrain.nodata_mask
    nodata: float | None = None
    if mask.any():
        inside = values[:, ~mask].astype(dtype)
        nodata = float("nan") if np.any(inside == np.asarray(-9999.0, dtype)) else -9999.0
    data = np.where(mask[None], np.nan if nodata is None else nodata, values).astype(dtype)
    driver = "COG" if outputs.options.cog else "GTiff"
    profile = {"driver": driver, "height": terrain.shape[0], "width": terrain.shape[1],
               "count": values.shape[0], "dtype": dtype, "transform": terrain.transform,
               "crs": RioCRS.from_wkt(terrain.crs_wkt) if terrain.crs_wkt else None, "nodata": nodata,
               **(COG_DEFAULTS if outputs.options.cog else GTIFF_DEFAULTS),
               **outputs.options.creation_options}
    with atomic_path(outputs.path) as tmp:
        try:
            with rasterio.open(tmp, "w", **profile) as dst:
                dst.write(data)
                dst.update_tags(**{k: str(v) for k, v in tags.items()})
                for band, text in enumerate(descriptions, start=1):
                    dst.set_band_description(band, text)
                dst.units = ("metre",) * values.shape[0]
        except (RasterioIOError, ValueError) as exc:
            raise InputError(f"cannot write {outputs.path.name}: {str(exc).splitlines()[0]}.") from None
