"""The maps of a report, drawn in memory on the axes of the raster's CRS
(:mod:`unerode_cli.viz.report_maps`)."""

from __future__ import annotations

import math

import numpy as np

from unerode_cli.io.terrain import Terrain
from unerode_cli.viz.report_html import png_bytes
from unerode_cli.viz.report_maps import MapFrame, save_field_map, save_relief_map

#: Short names of the CRS axis units.
_UNITS = {"metre": "m", "meter": "m", "kilometre": "km", "foot": "ft", "US survey foot": "US ft",
          "degree": "°"}


def map_frame(terrain: Terrain) -> MapFrame:
    """The frame of ``terrain``'s maps: its cells' outer edges in CRS coordinates (from the
    affine transform: left = c, top = f, right = c + nx·a, bottom = f + ny·e) and axis labels
    naming the coordinate, its unit and the CRS (its EPSG code when it has one); in degrees,
    a degree of latitude drawn 1 / cos(latitude) times as long as one of longitude."""
    t = terrain.transform
    ny, nx = terrain.shape
    extent = (t.c, t.c + nx * t.a, t.f + ny * t.e, t.f)
    if not terrain.crs_wkt:
        return MapFrame(extent, "x (raster without CRS)", "y (raster without CRS)")
    from pyproj import CRS
    from pyproj.exceptions import CRSError

    try:
        crs = CRS.from_wkt(terrain.crs_wkt)
    except CRSError:
        return MapFrame(extent, "x (unreadable CRS)", "y (unreadable CRS)")
    unit = crs.axis_info[0].unit_name if crs.axis_info else ""
    unit = _UNITS.get(unit, unit)
    epsg = crs.to_epsg(min_confidence=70)
    name = f"{crs.name} (EPSG:{epsg})" if epsg else crs.name
    if crs.is_geographic:
        latitude = math.radians(0.5 * (extent[2] + extent[3]))
        return MapFrame(extent, f"longitude ({unit})\n{name}", f"latitude ({unit})",
                        1.0 / max(math.cos(latitude), 0.05))
    return MapFrame(extent, f"easting ({unit})\n{name}", f"northing ({unit})")


def relief_png(terrain: Terrain, title: str, label: str = "elevation (m)") -> bytes:
    """A shaded-relief map of ``terrain`` (PNG bytes)."""
    return png_bytes(lambda f: save_relief_map(terrain.elevation, terrain.dx, terrain.dy, map_frame(terrain),
                                               f, title=title, label=label))


def field_png(values: np.ndarray, relief: Terrain, label: str, title: str, cmap: str = "magma_r",
              diverging: bool = False) -> bytes:
    """A map of ``values`` (float[ny, nx] on ``relief``'s grid) over the hillshade of ``relief``
    (PNG bytes)."""
    frame = map_frame(relief)
    return png_bytes(lambda f: save_field_map(values, relief.elevation, relief.dx, relief.dy, frame, f, label,
                                              title=title, cmap=cmap, diverging=diverging))
