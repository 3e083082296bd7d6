"""Cropping a heightfield to a box and resampling it to another cell size, on its own CRS
(``convert --crop``, ``--cell-size``): e.g. the coarse map and the fine window of a nested run
(000 §6.3.1)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from affine import Affine
from rasterio.enums import Resampling
from rasterio.warp import reproject

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import cell_size_metres
from unerode_cli.io.terrain import Terrain


def crop(terrain: Terrain, bounds: tuple[float, float, float, float]) -> Terrain:
    """The cells whose centres lie in ``bounds`` = (xmin, ymin, xmax, ymax), in the CRS's units;
    InputError when the box holds no cell."""
    xmin, ymin, xmax, ymax = bounds
    if not (xmin < xmax and ymin < ymax):
        raise InputError(f"--crop needs XMIN < XMAX and YMIN < YMAX, got {xmin:g},{ymin:g},"
                         f"{xmax:g},{ymax:g}.")
    ny, nx = terrain.shape
    inverse = ~terrain.transform
    cols, rows = inverse @ (np.array([xmin, xmax]), np.array([ymax, ymin]))
    c0, c1 = sorted(cols)
    r0, r1 = sorted(rows)
    first_col, last_col = max(math.ceil(c0 - 0.5), 0), min(math.floor(c1 - 0.5), nx - 1)
    first_row, last_row = max(math.ceil(r0 - 0.5), 0), min(math.floor(r1 - 0.5), ny - 1)
    if first_col > last_col or first_row > last_row:
        raise InputError(f"--crop {xmin:g},{ymin:g},{xmax:g},{ymax:g} holds no cell centre of the DEM.")
    window = terrain.elevation[first_row:last_row + 1, first_col:last_col + 1].copy()
    transform = terrain.transform * Affine.translation(first_col, first_row)
    return dataclasses.replace(terrain, elevation=window, transform=transform, tags=dict(terrain.tags))


def resample(terrain: Terrain, cell_size: float) -> Terrain:
    """The terrain on square cells of ``cell_size`` (in the CRS's units) over the same extent
    (rounded to whole cells): the average of the source cells when coarser, bilinear when
    finer; a cell is nodata when no valid source cell falls in it."""
    if not (math.isfinite(cell_size) and cell_size > 0):
        raise InputError(f"--cell-size must be a positive number, got {cell_size:g}.")
    t = terrain.transform
    ny, nx = terrain.shape
    width, height = abs(t.a) * nx, abs(t.e) * ny
    cols, rows = max(round(width / cell_size), 1), max(round(height / cell_size), 1)
    transform = Affine(math.copysign(cell_size, t.a), 0.0, t.c, 0.0, math.copysign(cell_size, t.e), t.f)
    source = np.where(terrain.nodata_mask, np.nan, terrain.elevation)
    target = np.full((rows, cols), np.nan)
    coarser = cell_size > min(abs(t.a), abs(t.e))
    reproject(source, target, src_transform=t, dst_transform=transform,
              src_crs=terrain.crs_wkt or None, dst_crs=terrain.crs_wkt or None,
              src_nodata=np.nan, dst_nodata=np.nan,
              resampling=Resampling.average if coarser else Resampling.bilinear)
    size = cell_size_metres(terrain.crs_wkt, transform, (rows, cols), "the resampled DEM")
    return dataclasses.replace(terrain, elevation=target, transform=transform, dx=size.dx,
                               dy=size.dy, tags=dict(terrain.tags))
