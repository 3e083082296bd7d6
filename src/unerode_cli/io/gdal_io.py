"""Read any single-band raster GDAL reads; write GeoTIFF, Cloud-Optimized GeoTIFF or another
GDAL format chosen by the output's extension."""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import rasterio
from rasterio.crs import CRS as RioCRS
from rasterio.drivers import driver_from_extension
from rasterio.errors import DriverRegistrationError, RasterioIOError

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import cell_size_metres
from unerode_cli.io.terrain import Terrain

#: Metadata carried from input to output: these keys, and every key starting with "UNERODE_".
KEPT_TAGS = ("AREA_OR_POINT",)
KEPT_PREFIX = "UNERODE_"


def kept(key: str) -> bool:
    """Whether a metadata key travels from input to output."""
    return key in KEPT_TAGS or key.startswith(KEPT_PREFIX)

#: GeoTIFF defaults for float DEMs (DESIGN §5); ``--co`` entries override them.
GTIFF_DEFAULTS = {
    "COMPRESS": "DEFLATE",
    "PREDICTOR": "3",
    "TILED": "YES",
    "BLOCKXSIZE": "256",
    "BLOCKYSIZE": "256",
    "BIGTIFF": "IF_SAFER",
    "NUM_THREADS": "ALL_CPUS",
}
COG_DEFAULTS = {"COMPRESS": "DEFLATE", "PREDICTOR": "YES", "BIGTIFF": "IF_SAFER",
                "NUM_THREADS": "ALL_CPUS"}


@dataclass(frozen=True)
class WriteOptions:
    """How to write a raster.

    Attributes:
        dtype: "float32" (default), "float64", or an integer type for codes (e.g. "uint8").
        cog: write a Cloud-Optimized GeoTIFF.
        creation_options: GDAL creation options (override the defaults).
    """

    dtype: str = "float32"
    cog: bool = False
    creation_options: dict[str, str] = field(default_factory=dict)


def read_gdal(path: Path, band: int | None = None) -> Terrain:
    """Read one band of a GDAL raster as a Terrain (nodata and NaN/inf cells → NaN)."""
    try:
        src = rasterio.open(path)
    except RasterioIOError as exc:
        raise InputError(f"{path} is not a raster that GDAL can read ({_first_line(exc)}).") from None
    with src:
        if band is None:
            if src.count > 1:
                print(f"note: {path} has {src.count} bands; reading band 1 (choose with --band).",
                      file=sys.stderr)
            band = 1
        if not 1 <= band <= src.count:
            raise InputError(f"{path} has {src.count} band(s); band {band} does not exist.")
        data = src.read(band).astype(np.float64)
        valid = src.read_masks(band) > 0
        crs_wkt = src.crs.to_wkt() if src.crs else ""
        size = cell_size_metres(crs_wkt, src.transform, data.shape, str(path))
        tags = {k: v for k, v in src.tags().items() if kept(k)}
        if src.units and src.units[band - 1]:
            tags["UNIT"] = src.units[band - 1]
        nodata = src.nodatavals[band - 1]
        transform = src.transform
    non_finite = valid & ~np.isfinite(data)
    if non_finite.any():
        print(f"note: {int(non_finite.sum())} NaN/inf cells in {path} are treated as nodata.",
              file=sys.stderr)
    data[~valid | non_finite] = np.nan
    return Terrain(data, size.dx, size.dy, crs_wkt, transform, nodata, tags)


def write_gdal(terrain: Terrain, path: Path, options: WriteOptions) -> None:
    """Write ``terrain`` to ``path`` (a temporary path with the final extension: see
    paths.atomic_path).

    The driver follows the extension of ``path``; GeoTIFF gets DEFLATE,
    floating-point predictor, 256² tiles and BIGTIFF when needed, or COG layout with ``cog``.
    """
    driver = _driver_for(path, options.cog)
    nodata = output_nodata(terrain)
    data = np.where(terrain.nodata_mask, nodata, terrain.elevation).astype(options.dtype)
    profile = {
        "driver": driver,
        "height": terrain.shape[0],
        "width": terrain.shape[1],
        "count": 1,
        "dtype": options.dtype,
        "crs": RioCRS.from_wkt(terrain.crs_wkt) if terrain.crs_wkt else None,
        "transform": terrain.transform,
        "nodata": nodata,
    }
    if driver == "GTiff":
        profile.update(GTIFF_DEFAULTS)
    elif driver == "COG":
        profile.update(COG_DEFAULTS)
    if driver in ("GTiff", "COG") and np.issubdtype(np.dtype(options.dtype), np.integer):
        profile["PREDICTOR"] = "2"  # horizontal differencing: the floating-point one needs floats
    profile.update(options.creation_options)
    try:
        with rasterio.open(path, "w", **profile) as dst:
            dst.write(data, 1)
            dst.update_tags(**{k: v for k, v in terrain.tags.items() if kept(k)})
            if "UNIT" in terrain.tags:
                dst.units = (terrain.tags["UNIT"],)
    except (RasterioIOError, DriverRegistrationError, ValueError) as exc:
        raise InputError(f"cannot write {path.name}: {_first_line(exc)}.") from None


def output_nodata(terrain: Terrain) -> float | None:
    """The nodata value to write: the terrain's, else −9999 when it has nodata cells.

    Should a valid elevation equal that value in float32, NaN is used instead so that no
    valid cell is ever read back as nodata.
    """
    candidate = terrain.nodata
    if candidate is None:
        if not terrain.nodata_mask.any():
            return None
        candidate = -9999.0
    candidate = float(candidate)
    valid = terrain.elevation[~terrain.nodata_mask].astype(np.float32)
    return float("nan") if np.any(valid == np.float32(candidate)) else candidate


def _driver_for(path: Path, cog: bool) -> str:
    suffix = path.suffix
    if suffix.lower() in (".tif", ".tiff"):
        return "COG" if cog else "GTiff"
    if cog:
        raise InputError("--cog needs a .tif output.")
    try:
        return driver_from_extension(suffix)
    except ValueError:
        raise InputError(f"no raster format is known for the extension '{suffix}'.") from None


def _first_line(exc: Exception) -> str:
    return str(exc).strip().splitlines()[0].rstrip(".") if str(exc).strip() else type(exc).__name__
