"""Georeferencing of generated grids: a CRS, a centre and a cell size in metres → a transform."""

from __future__ import annotations

from affine import Affine
from pyproj import CRS, Transformer
from pyproj.exceptions import CRSError

from unerode_cli.errors import InputError


def parse_crs(text: str) -> CRS:
    """A CRS from 'EPSG:n', WKT or a PROJ string; bad text is bad input."""
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
    """
    if centre is None:
        centre = _area_of_use_centre(crs)
    ny, nx = shape
    if crs.is_geographic:
        lon, lat = centre
        geod = crs.get_geod()
        _, _, metres_per_deg_lon = geod.inv(lon - 0.5, lat, lon + 0.5, lat)
        _, _, metres_per_deg_lat = geod.inv(lon, lat - 0.5, lon, lat + 0.5)
        px, py = cell_m / metres_per_deg_lon, cell_m / metres_per_deg_lat
    else:
        unit = crs.axis_info[0].unit_conversion_factor if crs.axis_info else 1.0
        px = py = cell_m / unit
    x0, y0 = centre[0] - px * nx / 2.0, centre[1] + py * ny / 2.0
    return Affine(px, 0.0, x0, 0.0, -py, y0)


def _area_of_use_centre(crs: CRS) -> tuple[float, float]:
    area = crs.area_of_use
    if area is None:
        return (0.0, 0.0)
    lon, lat = (area.west + area.east) / 2.0, (area.south + area.north) / 2.0
    if crs.is_geographic:
        return (lon, lat)
    x, y = Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(lon, lat)
    return (float(x), float(y))
