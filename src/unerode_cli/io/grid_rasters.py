"""Rasters that must lie on a DEM's grid (shape, transform and CRS checked): one band
(parameter maps, masks, ice thickness, earlier snapshots) or every band (layer stacks, velocity
fields), and multi-band GeoTIFFs written on that grid."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rasterio
from affine import Affine
from pyproj import CRS
from rasterio.crs import CRS as RioCRS
from rasterio.errors import RasterioIOError

from unerode_cli.errors import InputError
from unerode_cli.io.gdal_io import WriteOptions, output_format
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.paths import atomic_path
from unerode_cli.io.rasters import read_terrain
from unerode_cli.io.terrain import Terrain


def same_crs(a_wkt: str, b_wkt: str) -> bool:
    """Whether two WKT strings name the same CRS (both empty counts as the same)."""
    if not a_wkt or not b_wkt:
        return a_wkt == b_wkt
    return CRS.from_wkt(a_wkt) == CRS.from_wkt(b_wkt)


def check_on_grid(shape: tuple[int, int], transform: Affine, crs_wkt: str, terrain: Terrain,
                  path: Path, what: str) -> None:
    """Refuse a raster of ``shape``, ``transform`` and ``crs_wkt`` that does not lie on
    ``terrain``'s grid (``what`` names it in messages)."""
    if tuple(shape) != terrain.shape:
        raise InputError(
            f"{what} raster {path} has {shape[0]} × {shape[1]} cells but the DEM has "
            f"{terrain.shape[0]} × {terrain.shape[1]}."
        )
    if not transform.almost_equals(terrain.transform, precision=1e-9 * max(terrain.dx, 1)):
        raise InputError(f"{what} raster {path} is not aligned with the DEM (different transform).")
    if not same_crs(crs_wkt, terrain.crs_wkt):
        raise InputError(f"{what} raster {path} is not in the DEM's CRS.")


def load_on_grid(path: Path, terrain: Terrain, what: str) -> np.ndarray:
    """Read a raster that must lie on ``terrain``'s grid (shape, transform and CRS checked)."""
    return read_on_grid(path, terrain, what).elevation


def read_on_grid(path: Path, terrain: Terrain, what: str, georef: InputGeoref | None = None) -> Terrain:
    """Read a raster, with its tags and what ``georef`` assigns, that must lie on ``terrain``'s
    grid (shape, transform and CRS checked; ``what`` names it in messages)."""
    layer = read_terrain(path, georef=georef)
    check_on_grid(layer.shape, layer.transform, layer.crs_wkt, terrain, path, what)
    return layer


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
        check_on_grid(src.shape, src.transform, src.crs.to_wkt() if src.crs else "", terrain, path, what)
        values = src.read().astype(np.float64)
        valid = src.read_masks() > 0
        descriptions = tuple(d or "" for d in src.descriptions)
    values[~valid] = np.nan
    return Bands(values, descriptions)


def write_bands(values: np.ndarray, terrain: Terrain, path: Path, options: WriteOptions,
                descriptions: list[str], tags: dict[str, Any]) -> None:
    """Write float[bands, ny, nx] on ``terrain``'s grid as a multi-band GeoTIFF (or COG),
    atomically; nodata cells of the terrain are written as nodata (−9999, or NaN should a
    value equal it). Band descriptions and dataset ``tags`` are kept; units are metres."""
    if path.suffix.lower() not in (".tif", ".tiff"):
        raise InputError(f"a multi-band output must be a GeoTIFF (.tif), got {path.name}.")
    dtype = options.dtype
    mask = terrain.nodata_mask
    nodata: float | None = None
    if mask.any():
        inside = values[:, ~mask].astype(dtype)
        nodata = float("nan") if np.any(inside == np.asarray(-9999.0, dtype)) else -9999.0
    data = np.where(mask[None], np.nan if nodata is None else nodata, values).astype(dtype)
    fmt = output_format(path, options.cog)
    profile = {"driver": fmt.driver, "height": terrain.shape[0], "width": terrain.shape[1],
               "count": values.shape[0], "dtype": dtype, "transform": terrain.transform,
               "crs": RioCRS.from_wkt(terrain.crs_wkt) if terrain.crs_wkt else None, "nodata": nodata,
               **fmt.defaults, **options.creation_options}
    with atomic_path(path) as tmp:
        try:
            with rasterio.open(tmp, "w", **profile) as dst:
                dst.write(data)
                dst.update_tags(**{k: str(v) for k, v in tags.items()})
                for band, text in enumerate(descriptions, start=1):
                    dst.set_band_description(band, text)
                dst.units = ("metre",) * values.shape[0]
        except (RasterioIOError, ValueError) as exc:
            raise InputError(f"cannot write {path.name}: {str(exc).splitlines()[0]}.") from None
