"""Georeferencing assigned to the heightfields a command reads (``--crs``, ``--cell-size``,
``--nodata``), as GDAL's ``-a_srs``, ``-a_ullr`` and ``-a_nodata`` do.

``--crs`` and ``--cell-size`` fill in what an input lacks: a CRS for an input without one, a
grid for an input without a geotransform (an EXR from Houdini, a PNG); an input that already
has a different CRS or cell size is refused, since assigning would silently move it (nothing
here reprojects). ``--nodata`` declares the input's nodata value: cells equal to it are nodata
(NaN) and it is the nodata value written to the outputs.

A raster that must lie on a DEM's grid (a parameter raster) takes that DEM's CRS and transform
(as read, so with what ``--crs`` and ``--cell-size`` assigned to it) when it has none of its
own (:meth:`InputGeoref.on_grid`); one with another CRS, transform or shape is left as it is,
for the grid check (``io.grid_rasters.check_on_grid``) to refuse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.io.georef import parse_crs

#: Relative tolerance of a file's pixel size against ``--cell-size`` (rounding of its coefficients).
CELL_SIZE_RTOL = 1e-9


@dataclass(frozen=True)
class InputGeoref:
    """What the user assigns to every heightfield a command reads.

    Attributes:
        crs: the CRS as given (``EPSG:32632``, WKT, PROJ JSON or string); None: keep the file's.
        cell_size: the square pixel size of inputs without a geotransform, in the CRS's units
            (metres without a CRS or in a metric projection); the grid's lower-left corner is
            put at (0, 0). None: keep the file's (1 m for an EXR without one).
        nodata: the input's nodata value (replaces the one the file declares); None: the file's.
        grid_crs: the CRS (WKT) an input without one takes when ``crs`` is None ("": none).
        grid_transform: the transform an input without one takes when ``cell_size`` is None.
    """

    crs: str | None = None
    cell_size: float | None = None
    nodata: float | None = None
    grid_crs: str = ""
    grid_transform: Affine | None = None

    @classmethod
    def on_grid(cls, crs_wkt: str, transform: Affine) -> InputGeoref:
        """What a raster that must lie on a DEM's grid takes when it has no CRS (``crs_wkt``,
        the DEM's WKT) or no geotransform (``transform``, the DEM's)."""
        return cls(grid_crs=crs_wkt, grid_transform=transform)

    def __post_init__(self) -> None:
        if self.cell_size is not None and not (math.isfinite(self.cell_size) and self.cell_size > 0):
            raise InputError(f"--cell-size must be a positive number, got {self.cell_size:g}.")
        if self.crs is not None:
            parse_crs(self.crs)  # refuses text pyproj cannot parse

    @property
    def given(self) -> bool:
        return self.crs is not None or self.cell_size is not None or self.nodata is not None

    def crs_wkt(self) -> str:
        """The assigned CRS as WKT2 (2019), "" when none is assigned."""
        return parse_crs(self.crs).to_wkt() if self.crs is not None else ""

    def transform(self, shape: tuple[int, int]) -> Affine | None:
        """The north-up transform of a grid of ``shape`` (rows, columns) with ``--cell-size``
        cells and its lower-left corner at (0, 0); None without ``--cell-size``."""
        if self.cell_size is None:
            return None
        return Affine(self.cell_size, 0.0, 0.0, 0.0, -self.cell_size, shape[0] * self.cell_size)

    def resolve_crs(self, file_wkt: str, path: object) -> str:
        """The CRS (WKT) to use for a file whose own is ``file_wkt`` ("" when none): the file's
        when nothing is assigned, the assigned one when the file has none or the same one;
        refused (InputError) when the file has another. Without an assigned CRS, a file
        without one takes ``grid_crs``."""
        if self.crs is None:
            return file_wkt or self.grid_crs
        assigned = parse_crs(self.crs)
        if not file_wkt:
            return assigned.to_wkt()
        own = parse_crs(file_wkt)
        if own.equals(assigned, ignore_axis_order=True):
            return file_wkt
        raise InputError(f"{path} already has a CRS ({own.name}), not {assigned.name}: --crs only assigns a "
                         "CRS to inputs that have none; leave --crs out, or reproject the file first "
                         "(e.g. gdalwarp -t_srs).")

    def resolve_transform(self, file_transform: Affine | None, shape: tuple[int, int],
                          path: object) -> Affine | None:
        """The transform to use for a file whose own is ``file_transform`` (None when it has
        none): the file's unless it has none and ``--cell-size`` is given; refused (InputError)
        when the file's pixel size is not ``--cell-size``. Without ``--cell-size``, a file
        without a transform takes ``grid_transform``."""
        if self.cell_size is None:
            return file_transform if file_transform is not None else self.grid_transform
        if file_transform is None:
            return self.transform(shape)
        px, py = file_transform.a, -file_transform.e
        if not all(math.isclose(p, self.cell_size, rel_tol=CELL_SIZE_RTOL) for p in (px, py)):
            raise InputError(f"{path} already has a geotransform with {px:g} × {py:g} pixels, not "
                             f"{self.cell_size:g}: --cell-size only assigns a grid to inputs without one; "
                             "leave --cell-size out (convert --cell-size resamples).")
        return file_transform

    def mask_nodata(self, data: np.ndarray) -> None:
        """Set the cells of ``data`` (float64[ny, nx], in place) equal to ``--nodata`` to NaN, as
        stored (float64) or as float32 storage rounds it."""
        if self.nodata is None or not math.isfinite(self.nodata):
            return
        data[(data == self.nodata) | (data == float(np.float32(self.nodata)))] = np.nan
