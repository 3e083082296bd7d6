"""Cell sizes in metres from a raster's CRS and affine transform (DESIGN §4)."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from affine import Affine
from pyproj import CRS

from unerode_cli.errors import InputError

#: Latitude span (degrees) above which one centre-latitude cell size is a poor approximation.
MAX_LATITUDE_SPAN_DEG = 5.0
#: How far (degrees) a geographic raster's edge may pass ±90° (rounding of its corner coordinates).
POLE_TOLERANCE_DEG = 1e-9


@dataclass(frozen=True)
class CellSize:
    """East-west (dx) and north-south (dy) cell size in metres, and how they were obtained."""

    dx: float
    dy: float
    how: str


def check_north_up(transform: Affine, source: str) -> None:
    """Refuse non-finite, rotated, sheared or south-up transforms with one sentence."""
    if not all(math.isfinite(v) for v in transform[:6]):
        raise InputError(f"{source} has a geotransform with non-finite coefficients "
                         f"({', '.join(f'{v:g}' for v in transform[:6])}); give it a finite origin and "
                         "pixel size (e.g. gdal_translate -a_ullr).")
    if transform.b != 0 or transform.d != 0:
        raise InputError(
            f"{source} has a rotated or sheared geotransform; warp it to a north-up grid first "
            "(e.g. gdalwarp)."
        )
    if transform.a <= 0 or transform.e >= 0:
        raise InputError(
            f"{source} is not north-up (pixel sizes {transform.a:g}, {transform.e:g}); "
            "warp it to a north-up grid first (e.g. gdalwarp)."
        )


def cell_size_metres(crs_wkt: str, transform: Affine, shape: tuple[int, int], source: str) -> CellSize:
    """Cell size in metres of a north-up raster.

    Projected CRS: pixel size times the CRS's linear unit (feet converted). Geographic CRS:
    geodesic lengths of one pixel at the raster's centre on the CRS's ellipsoid (dx ≠ dy);
    a warning is printed when the raster spans more than ``MAX_LATITUDE_SPAN_DEG`` degrees of
    latitude. No CRS: the pixel size is assumed to be in metres, and that is said on stderr.

    Refused (InputError): a transform with non-finite coefficients or an extent that is not
    finite, a geographic raster whose rows reach past a pole (beyond ±90° latitude), and a
    cell size that does not come out a finite positive length.
    """
    check_north_up(transform, source)
    _check_finite_extent(transform, shape, source)
    px, py = transform.a, -transform.e
    if not crs_wkt:
        print(f"note: {source} has no CRS; its pixel size is taken to be in metres.", file=sys.stderr)
        size = CellSize(px, py, "no CRS: pixel size assumed in metres")
    else:
        crs = CRS.from_wkt(crs_wkt)
        if crs.is_geographic:
            size = _geographic_cell_size(crs, transform, shape, source)
        else:
            unit = crs.axis_info[0].unit_conversion_factor if crs.axis_info else 1.0
            name = crs.axis_info[0].unit_name if crs.axis_info else "metre"
            size = CellSize(px * unit, py * unit, f"projected CRS in {name}")
    if not all(math.isfinite(v) and v > 0 for v in (size.dx, size.dy)):
        raise InputError(f"the cells of {source} come out {size.dx:g} m × {size.dy:g} m, not a finite "
                         "positive size; give it a finite pixel size.")
    return size


def _check_finite_extent(transform: Affine, shape: tuple[int, int], source: str) -> None:
    """Refuse a raster whose far corner is not finite (a huge pixel size times its cells)."""
    ny, nx = shape
    right, bottom = transform @ (nx, ny)
    if not (math.isfinite(right) and math.isfinite(bottom)):
        raise InputError(f"the extent of {source} is not finite ({nx:,} columns of {transform.a:g} and "
                         f"{ny:,} rows of {-transform.e:g} CRS units); give a smaller pixel size or fewer "
                         "cells.")


def _geographic_cell_size(crs: CRS, transform: Affine, shape: tuple[int, int], source: str) -> CellSize:
    ny, nx = shape
    top, bottom = transform.f, transform.f + ny * transform.e
    if top > 90.0 + POLE_TOLERANCE_DEG or bottom < -90.0 - POLE_TOLERANCE_DEG:
        raise InputError(f"{source} is in geographic coordinates and its rows reach latitudes {bottom:.6g}° "
                         f"to {top:.6g}°, past the pole; only latitudes in [−90°, 90°] exist: fix its "
                         "geotransform, or use a projected CRS (e.g. polar stereographic) near a pole.")
    lon_c, lat_c = transform @ (nx / 2.0, ny / 2.0)
    half_lon, half_lat = transform.a / 2.0, -transform.e / 2.0
    span = ny * -transform.e
    if span > MAX_LATITUDE_SPAN_DEG:
        print(
            f"warning: {source} spans {span:.1f}° of latitude; one cell size computed at its "
            f"centre ({lat_c:.2f}°) is a rough approximation.",
            file=sys.stderr,
        )
    geod = crs.get_geod()
    _, _, dx = geod.inv(lon_c - half_lon, lat_c, lon_c + half_lon, lat_c)
    _, _, dy = geod.inv(lon_c, lat_c - half_lat, lon_c, lat_c + half_lat)
    return CellSize(float(dx), float(dy), f"geographic CRS, geodesic at {lat_c:.4f}° latitude")
