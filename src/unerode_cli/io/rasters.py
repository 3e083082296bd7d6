"""Read and write heightfields by file extension: ``.exr`` via OpenEXR, anything else via GDAL."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import OpenEXR
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.io.exr_io import read_exr, read_exr_georef, write_exr
from unerode_cli.io.gdal_io import (
    READ_BYTES_PER_CELL,
    WriteOptions,
    check_gdal_writable,
    read_gdal,
    read_gdal_header,
    writable_extensions,
    write_gdal,
)
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.paths import atomic_path
from unerode_cli.io.terrain import Terrain

#: What checks a read's memory estimate before the cells are read: ``check(nbytes, what, change)``
#: raises InputError when ``nbytes`` do not fit (``run.memory`` registers its check; None: no check).
_memory_check: Callable[[float, str, str], None] | None = None


def set_memory_check(check: Callable[[float, str, str], None] | None) -> None:
    """Have :func:`read_terrain` call ``check(nbytes, what, change)`` before it reads cells."""
    global _memory_check
    _memory_check = check


def is_exr(path: Path) -> bool:
    return path.suffix.lower() == ".exr"


@dataclass(frozen=True)
class RasterHeader:
    """What a heightfield file says before its cells are read: ``shape`` (rows, columns) and
    the peak bytes per cell of reading it (:func:`read_terrain`); for GDAL rasters also the
    CRS (WKT), transform, nodata value and kept tags (an EXR's are read with its cells)."""

    path: Path
    shape: tuple[int, int]
    read_bytes_per_cell: int
    crs_wkt: str = ""
    transform: Affine | None = None
    nodata: float | None = None
    tags: dict[str, str] = field(default_factory=dict)

    @property
    def cells(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def read_bytes(self) -> float:
        """Peak bytes of reading every cell."""
        return float(self.cells) * self.read_bytes_per_cell

    def size_text(self) -> str:
        """"{rows} × {columns} cells", for sentences."""
        return f"{self.shape[0]:,} × {self.shape[1]:,} cells"


def _check_input(path: Path) -> None:
    if not path.exists():
        raise InputError(f"input {path} does not exist.")
    if path.is_dir():
        raise InputError(f"input {path} is a folder, not a raster file.")


def read_header(path: Path, band: int | None = None, georef: InputGeoref | None = None) -> RasterHeader:
    """The header of a heightfield file, its cells unread (for memory estimates and windows),
    with what ``georef`` assigns (``--crs``, ``--cell-size``, ``--nodata``): refuses what
    :func:`read_terrain` would refuse before reading cells (missing file, folder, unreadable
    format, missing band, no georeferencing, an assignment the file contradicts)."""
    _check_input(path)
    georef = georef or InputGeoref()
    if is_exr(path):
        try:
            with OpenEXR.File(str(path), header_only=True) as exr:
                header = dict(exr.header())
                low, high = header["dataWindow"]
                channels = len(header.get("channels", [])) or 1
        except Exception as exc:  # the bindings raise bare RuntimeError/OSError subclasses
            raise InputError(f"{path} is not an OpenEXR file that can be read ({exc}).") from None
        shape = (int(high[1]) - int(low[1]) + 1, int(high[0]) - int(low[0]) + 1)
        where = read_exr_georef(path, header, shape, georef)
        # every channel is read (float32 at most), the chosen one cast to float64, masks
        return RasterHeader(path, shape, 4 * channels + READ_BYTES_PER_CELL, where.crs_wkt, where.transform,
                            where.nodata)
    gdal = read_gdal_header(path, band, georef)
    return RasterHeader(path, gdal.shape, gdal.read_bytes_per_cell, gdal.crs_wkt, gdal.transform,
                        gdal.nodata, gdal.tags)


def read_terrain(path: Path, band: int | None = None, channel: str | None = None,
                 window: tuple[slice, slice] | None = None, georef: InputGeoref | None = None) -> Terrain:
    """Read a heightfield (metres) from a GDAL raster or an OpenEXR file; never writes to it.

    ``georef`` assigns a CRS, a grid and a nodata value to an input that lacks them
    (:class:`~unerode_cli.io.input_georef.InputGeoref`; refused when the file has others).

    ``window`` (rows, columns: slices of cell indices within the raster) reads those cells
    only from a GDAL raster (an EXR is read whole, then cut); the cell size stays that of the
    whole raster. Before any cell is read, the registered memory check (see
    :func:`set_memory_check`) is given the peak bytes of the read."""
    if _memory_check is not None:
        header = read_header(path, band, georef)
        cells = header.cells
        if window is not None and not is_exr(path):
            rows, cols = window
            cells = len(range(*rows.indices(header.shape[0]))) * len(range(*cols.indices(header.shape[1])))
        what = f"reading {path} ({header.size_text()})" if window is None or is_exr(path) else \
            f"reading {cells:,} cells of {path}"
        _memory_check(float(cells) * header.read_bytes_per_cell, what,
                      "crop it to the area needed first (convert --crop reads only that window), or use "
                      "a machine with more memory")
    _check_input(path)
    if not is_exr(path):
        return read_gdal(path, band, window, georef)
    terrain = read_exr(path, channel, georef)
    if window is None:
        return terrain
    rows, cols = window
    elevation = terrain.elevation[rows, cols].copy()
    transform = terrain.transform * Affine.translation(cols.start or 0, rows.start or 0)
    return Terrain(elevation, terrain.dx, terrain.dy, terrain.crs_wkt, transform, terrain.nodata,
                   dict(terrain.tags))


def check_writable(path: Path, options: WriteOptions) -> None:
    """Refuse, before any work, a heightfield output that could not be written: no extension
    or an unknown one, EXR with another dtype than float32 or with --cog or --co, --cog on a
    non-GeoTIFF, a dtype the format cannot hold, creation options its driver does not know or
    whose value it does not allow; a folder is refused as such."""
    if path.is_dir():
        raise InputError(f"cannot write {path}: it is a folder; give a file name inside it, e.g. "
                         f"{path / 'out.tif'}.")
    known = (".exr", *writable_extensions())
    if path.suffix.lower() not in known:
        what = f"'{path.suffix}' is no known raster extension" if path.suffix else "it has no extension"
        raise InputError(f"cannot write {path}: {what}; end its name with one of {', '.join(known)}.")
    if not is_exr(path):
        check_gdal_writable(path, options)
    elif options.dtype != "float32" or options.cog or options.creation_options:
        raise InputError("EXR outputs are always float32 ZIP; --dtype, --cog and --co do not apply.")


def write_terrain(terrain: Terrain, path: Path, options: WriteOptions | None = None) -> None:
    """Write atomically (temporary file beside ``path``, then rename), after check_writable."""
    options = options or WriteOptions()
    check_writable(path, options)
    if not is_exr(path):
        write_gdal(terrain, path, options)
        return
    with atomic_path(path) as tmp:
        write_exr(terrain, tmp)
