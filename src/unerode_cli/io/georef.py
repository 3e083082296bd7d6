"""Georeferencing of generated grids: a CRS, a centre and a cell size in metres → a transform."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from affine import Affine

from unerode_cli.errors import InputError

if TYPE_CHECKING:  # pyproj is imported where a CRS is made: the CLI declares its options without it
    from pyproj import CRS

#: Coordinates beyond this (CRS units) are taken as unusable: sizes and areas computed from
#: them overflow double precision.
_HUGE = 1e150


def parse_crs(text: str) -> CRS:
    """A CRS from 'EPSG:n', WKT or a PROJ string; bad text is bad input."""
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    try:
        return CRS.from_user_input(text)
    except CRSError:
        raise InputError(f"'{text}' is not a coordinate reference system pyproj knows.") from None


def centred_transform(
    crs: CRS, shape: tuple[int, int], cell_m: float, centre: tuple[float, float] | None
) -> Affine:
    """North-up transform of a grid of ``shape`` with ``cell_m`` metre cells around ``centre``.

    ``centre`` is in CRS units (lon, lat for a geographic CRS); by default the centre of the
    CRS's area of use. For a geographic CRS the pixel size in degrees is the one whose
    geodesic length is ``cell_m`` at the centre latitude (so dx, dy ≈ cell_m there).

    Refused (InputError, naming ``--centre``, ``--dx`` and ``--size``): a centre or a pixel
    size that is not finite, an extent that is not (cells too large for the numbers), and on a
    geographic CRS a centre off the globe or rows reaching past a pole.
    """
    if centre is None:
        centre = _area_of_use_centre(crs)
    if not all(math.isfinite(v) for v in centre):
        raise InputError(f"--centre must be two finite numbers, got {centre[0]:g},{centre[1]:g}.")
    ny, nx = shape
    if crs.is_geographic:
        lon, lat = centre
        if not (-180.0 <= lon <= 360.0 and -90.0 < lat < 90.0):
            raise InputError(f"--centre {lon:g},{lat:g} is not a longitude,latitude on the globe "
                             "(latitude strictly between −90° and 90°).")
        if abs(lat) + 0.5 > 90.0:
            raise InputError(f"--centre latitude {lat:g}° is within half a degree of the pole, where cells "
                             "of equal size in metres have no size in degrees; use a projected CRS there "
                             "(e.g. polar stereographic, EPSG:3413 or EPSG:3031).")
        geod = crs.get_geod()
        _, _, metres_per_deg_lon = geod.inv(lon - 0.5, lat, lon + 0.5, lat)
        _, _, metres_per_deg_lat = geod.inv(lon, lat - 0.5, lon, lat + 0.5)
        px, py = cell_m / metres_per_deg_lon, cell_m / metres_per_deg_lat
    else:
        unit = crs.axis_info[0].unit_conversion_factor if crs.axis_info else 1.0
        px = py = cell_m / unit
    x0, y0 = centre[0] - px * nx / 2.0, centre[1] + py * ny / 2.0
    x1, y1 = x0 + px * nx, y0 - py * ny
    finite = all(math.isfinite(v) and abs(v) < _HUGE for v in (px, py, x0, y0, x1, y1))
    if not (finite and px > 0 and py > 0):
        raise InputError(f"--dx {cell_m:g} m over {nx} cells gives a grid whose extent is not finite "
                         f"(x {x0:g} … {x1:g}); give a smaller --dx or --size.")
    if crs.is_geographic and px * nx > 360.0:
        raise InputError(f"the grid of {nx} columns of {cell_m:g} m at latitude {centre[1]:g}° would span "
                         f"{px * nx:.6g}° of longitude, more than the globe; give a smaller --dx or --size, "
                         "or use a projected CRS.")
    if crs.is_geographic and (y0 > 90.0 or y1 < -90.0):
        raise InputError(f"the grid of {ny} rows of {cell_m:g} m around latitude {centre[1]:g}° would "
                         f"reach latitudes {y1:.6g}° to {y0:.6g}°, past the pole; move --centre away from "
                         "the pole, give a smaller --dx or --size, or use a projected CRS (e.g. polar "
                         "stereographic).")
    return Affine(px, 0.0, x0, 0.0, -py, y0)


def _area_of_use_centre(crs: CRS) -> tuple[float, float]:
    from pyproj import Transformer

    area = crs.area_of_use
    if area is None:
        return (0.0, 0.0)
    lon, lat = (area.west + area.east) / 2.0, (area.south + area.north) / 2.0
    if crs.is_geographic:
        return (lon, lat)
    x, y = Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(lon, lat)
    return (float(x), float(y))
