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


def crop_window(transform: Affine, shape: tuple[int, int],
                bounds: tuple[float, float, float, float]) -> tuple[slice, slice]:
    """The rows and columns (slices of cell indices) of a grid (``transform``, ``shape`` =
    rows, columns) whose cell centres lie in ``bounds`` = (xmin, ymin, xmax, ymax), in the CRS's
    units; InputError when the box holds no cell or is not a finite box."""
    xmin, ymin, xmax, ymax = bounds
    if not all(math.isfinite(v) for v in bounds):
        raise InputError(f"--crop needs four finite numbers, got {xmin:g},{ymin:g},{xmax:g},{ymax:g}.")
    if not (xmin < xmax and ymin < ymax):
        raise InputError(f"--crop needs XMIN < XMAX and YMIN < YMAX, got {xmin:g},{ymin:g},"
                         f"{xmax:g},{ymax:g}.")
    ny, nx = shape
    inverse = ~transform
    cols, rows = inverse @ (np.array([xmin, xmax]), np.array([ymax, ymin]))
    c0, c1 = sorted(cols)
    r0, r1 = sorted(rows)
    first_col, last_col = max(math.ceil(c0 - 0.5), 0), min(math.floor(c1 - 0.5), nx - 1)
    first_row, last_row = max(math.ceil(r0 - 0.5), 0), min(math.floor(r1 - 0.5), ny - 1)
    if first_col > last_col or first_row > last_row:
        raise InputError(f"--crop {xmin:g},{ymin:g},{xmax:g},{ymax:g} holds no cell centre of the DEM.")
    return slice(first_row, last_row + 1), slice(first_col, last_col + 1)


def crop(terrain: Terrain, bounds: tuple[float, float, float, float]) -> Terrain:
    """The cells whose centres lie in ``bounds`` = (xmin, ymin, xmax, ymax), in the CRS's units;
    InputError when the box holds no cell."""
    rows, cols = crop_window(terrain.transform, terrain.shape, bounds)
    window = terrain.elevation[rows, cols].copy()
    transform = terrain.transform * Affine.translation(cols.start, rows.start)
    return dataclasses.replace(terrain, elevation=window, transform=transform, tags=dict(terrain.tags))


#: Peak bytes per target cell of :func:`resample`: the float64 target, and GDAL's working
#: copies of it while warping (about two more float64 values).
RESAMPLE_BYTES_PER_CELL = 24


def resampled_shape(transform: Affine, shape: tuple[int, int], cell_size: float) -> tuple[int, int]:
    """Rows and columns of the grid of square cells of ``cell_size`` (CRS units) over the extent
    of a grid (``transform``, ``shape``), as :func:`resample` makes it; InputError for a cell
    size that is not a finite positive number."""
    if not (math.isfinite(cell_size) and cell_size > 0):
        raise InputError(f"--cell-size must be a positive number, got {cell_size:g}.")
    ny, nx = shape
    width, height = abs(transform.a) * nx, abs(transform.e) * ny
    cols, rows = width / cell_size, height / cell_size
    if not (math.isfinite(cols) and math.isfinite(rows)) or max(cols, rows) > 2**53:
        raise InputError(f"--cell-size {cell_size:g} divides the DEM's extent into more cells than can be "
                         "counted; give a larger cell size.")
    return max(round(rows), 1), max(round(cols), 1)


def resample(terrain: Terrain, cell_size: float) -> Terrain:
    """The terrain on square cells of ``cell_size`` (in the CRS's units) over the same extent
    (rounded to whole cells): the average of the source cells when coarser, bilinear when
    finer; a cell is nodata when no valid source cell falls in it."""
    t = terrain.transform
    rows, cols = resampled_shape(t, terrain.shape, cell_size)
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
