"""Read any single-band raster GDAL reads; write GeoTIFF, Cloud-Optimized GeoTIFF or another
GDAL format chosen by the output's extension."""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import re
import sys
import tempfile
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from logging.handlers import BufferingHandler
from pathlib import Path

import numpy as np
import rasterio
import rasterio.shutil
from affine import Affine
from pyproj import CRS
from rasterio._err import CPLE_BaseError  # what GDAL's copy raises (not re-exported publicly)
from rasterio.crs import CRS as RioCRS
from rasterio.errors import NotGeoreferencedWarning, RasterioError, RasterioIOError
from rasterio.windows import Window

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import cell_size_metres
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.netcdf_raster import name_raster_variable
from unerode_cli.io.paths import atomic_path, place, staging_folder
from unerode_cli.io.terrain import Terrain

#: GDAL's block cache (MB) unless the user sets GDAL_CACHEMAX: rasters are read and written in
#: strips of whole rows, each stored block once, so a larger cache (GDAL's default: 5 % of the
#: memory) only holds decompressed blocks that are never read again.
GDAL_CACHE_MB = 64
os.environ.setdefault("GDAL_CACHEMAX", str(GDAL_CACHE_MB))

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

#: Map projections (EPSG method names) that GDAL's netCDF writer turns into CF grid mappings.
#: On some others (Hotine oblique Mercator, Krovak, Equal Earth) it aborts the whole process, so
#: a netCDF output in any other projection is refused.
CF_METHODS = frozenset({
    "Transverse Mercator", "Lambert Azimuthal Equal Area", "Lambert Conic Conformal (1SP)",
    "Lambert Conic Conformal (2SP)", "Albers Equal Area", "Mercator (variant A)", "Mercator (variant B)",
    "Popular Visualisation Pseudo Mercator", "Polar Stereographic (variant A)",
    "Polar Stereographic (variant B)", "Oblique Stereographic", "Lambert Cylindrical Equal Area",
})

#: What GDAL raises when a dataset cannot be written.
_WRITE_ERRORS = (RasterioError, CPLE_BaseError, ValueError)


@dataclass(frozen=True)
class Format:
    """A GDAL output format.

    Attributes:
        driver: GDAL driver name.
        by_copy: build the raster in memory, then copy it into the format (drivers that can only
            copy a dataset, or that keep nodata only when it is known at creation).
        defaults: creation options applied unless ``--co`` overrides them.
        projections: the map projections (EPSG method names) it can hold besides geographic
            coordinates; None: any.
    """

    driver: str
    by_copy: bool = False
    defaults: Mapping[str, str] = field(default_factory=dict)
    projections: frozenset[str] | None = None


_GTIFF = Format("GTiff", defaults=GTIFF_DEFAULTS)
_COG = Format("COG", defaults=COG_DEFAULTS)

#: Output formats by (lower-case) extension; those whose driver the bundled GDAL lacks are refused.
FORMATS = {
    ".tif": _GTIFF,
    ".tiff": _GTIFF,
    ".asc": Format("AAIGrid", by_copy=True),  # Arc/Info ASCII grid (+ .prj)
    ".img": Format("HFA"),  # Erdas Imagine
    ".bil": Format("ENVI", defaults={"INTERLEAVE": "BIL"}),  # ENVI band-interleaved (+ .hdr)
    # rasterio opens netCDF read-only; NetCDF-4 with DEFLATE, the variable named (netcdf_raster)
    ".nc": Format("netCDF", by_copy=True, defaults={"FORMAT": "NC4", "COMPRESS": "DEFLATE"},
                  projections=CF_METHODS),
    ".gpkg": Format("GPKG", by_copy=True),  # GeoPackage gridded coverage (float32 at most)
}


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


#: Peak bytes per cell of :func:`read_gdal`: the float64 elevations; the band is read in strips
#: of :data:`STRIP_CELLS` cells, cast by GDAL straight into them.
READ_BYTES_PER_CELL = 8
#: Cells of one strip of rows read or written at a time (whole rows, at least one).
STRIP_CELLS = 1 << 22


@dataclass(frozen=True)
class GdalHeader:
    """What a raster's header says, read without its cells: ``shape`` (rows, columns), the
    bytes of one stored cell (``itemsize``), CRS (WKT, "" without), transform, nodata value of
    the band and the kept tags."""

    shape: tuple[int, int]
    itemsize: int
    crs_wkt: str
    transform: Affine
    nodata: float | None
    tags: dict[str, str]
    bands: int

    @property
    def read_bytes_per_cell(self) -> int:
        """Peak bytes per cell of reading it with :func:`read_gdal` (strips of the stored
        cells cost no more per cell)."""
        return READ_BYTES_PER_CELL


def read_gdal_header(path: Path, band: int | None = None, georef: InputGeoref | None = None) -> GdalHeader:
    """The header of one band of a GDAL raster, with what ``georef`` assigns; refuses
    (InputError) a raster GDAL cannot read, a band it does not have, a raster without
    georeferencing (unless ``georef`` gives a cell size) and an assignment that contradicts
    the file (:class:`~unerode_cli.io.input_georef.InputGeoref`)."""
    with _open(path) as src:
        band = _band(src, path, band, note=False)
        return _header(src, path, band, georef or InputGeoref())


def read_gdal(path: Path, band: int | None = None,
              window: tuple[slice, slice] | None = None, georef: InputGeoref | None = None) -> Terrain:
    """Read one band of a GDAL raster as a Terrain (nodata and NaN/inf cells → NaN), with the
    CRS, grid and nodata value ``georef`` assigns (see :func:`read_gdal_header`).

    ``window`` (rows, columns: slices of cell indices, within the raster) reads those cells
    only; the cell size stays that of the whole raster (on a geographic raster, the geodesic
    size at its centre)."""
    georef = georef or InputGeoref()
    with _open(path) as src:
        band = _band(src, path, band, note=True)
        header = _header(src, path, band, georef)
        size = cell_size_metres(header.crs_wkt, header.transform, header.shape, str(path))
        transform = header.transform
        rio_window = None
        if window is not None:
            rows, cols = window
            rio_window = Window.from_slices(rows, cols)
            transform = header.transform * Affine.translation(rio_window.col_off, rio_window.row_off)
        rows, cols = (header.shape if rio_window is None else
                      (int(rio_window.height), int(rio_window.width)))
        try:
            data = np.empty((rows, cols), dtype=np.float64)
        except MemoryError:
            need = float(rows) * cols * header.read_bytes_per_cell / 2**30
            raise InputError(f"reading {path} ({rows:,} × {cols:,} cells) needs about {need:,.1f} GiB of "
                             "memory, more than could be allocated; crop it to the area needed first "
                             "(convert --crop reads only that window).") from None
        top, left = (0, 0) if rio_window is None else (int(rio_window.row_off), int(rio_window.col_off))
        try:
            non_finite, usable = _read_strips(src, band, data, top, left)
        except RasterioIOError as exc:
            raise _corrupt(path, exc) from None
        georef.mask_nodata(data)
        tags = header.tags
        if src.units and src.units[band - 1]:
            tags["UNIT"] = src.units[band - 1]
    if non_finite and usable:  # with no valid cell left, the job says so
        print(f"note: {non_finite} NaN/inf cells in {path} are treated as nodata.", file=sys.stderr)
    return Terrain(data, size.dx, size.dy, header.crs_wkt, transform, header.nodata, tags)


def strips(rows: int, cols: int) -> Iterator[tuple[int, int]]:
    """(first, end) rows of the strips of about :data:`STRIP_CELLS` cells that cover ``rows``
    rows of ``cols`` columns."""
    step = max(1, STRIP_CELLS // max(cols, 1))
    for first in range(0, rows, step):
        yield first, min(rows, first + step)


def _read_strips(src: rasterio.io.DatasetReader, band: int, data: np.ndarray, top: int,
                 left: int) -> tuple[int, bool]:
    """Read the band into ``data`` (float64[rows, cols], the cells from row ``top``, column
    ``left``) strip by strip, GDAL casting the stored type; nodata and NaN/inf cells → NaN.
    Returns (the number of valid cells that held NaN/inf, whether any cell is usable)."""
    rows, cols = data.shape
    non_finite = 0
    usable = False
    for first, end in strips(rows, cols):
        window = Window(left, top + first, cols, end - first)
        strip = data[first:end]
        src.read(band, window=window, out=strip)
        valid = src.read_masks(band, window=window) > 0
        finite = np.isfinite(strip)
        non_finite += int(np.count_nonzero(valid & ~finite))
        valid &= finite
        usable = usable or bool(valid.any())
        strip[~valid] = np.nan
    return non_finite, usable


@contextlib.contextmanager
def _open(path: Path) -> Iterator[rasterio.io.DatasetReader]:
    """The raster opened with rasterio (its "not georeferenced" warning left unsaid: the
    header check says it in a sentence); InputError when GDAL cannot open it."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NotGeoreferencedWarning)
            src = rasterio.open(path)
    except RasterioIOError as exc:
        if "not recognized as being in a supported file format" in str(exc):
            raise InputError(f"{path} is not a raster that GDAL can read ({_first_line(exc)}).") from None
        raise _corrupt(path, exc) from None
    with src:
        yield src


def _band(src: rasterio.io.DatasetReader, path: Path, band: int | None, note: bool) -> int:
    """The band to read: ``band``, else 1 (with a note when there are several and ``note``)."""
    if band is None:
        if src.count > 1 and note:
            print(f"note: {path} has {src.count} bands; reading band 1 (choose with --band).",
                  file=sys.stderr)
        band = 1
    if not 1 <= band <= src.count:
        raise InputError(f"{path} has {src.count} band(s); band {band} does not exist.")
    return band


def _header(src: rasterio.io.DatasetReader, path: Path, band: int, georef: InputGeoref) -> GdalHeader:
    """The header of an open raster with what ``georef`` assigns; a raster without a
    geotransform (GDAL gives the identity then: a PNG or JPEG, say) is refused as not
    georeferenced unless ``georef`` gives its cell size."""
    crs_wkt = georef.resolve_crs(src.crs.to_wkt() if src.crs else "", path)
    has_transform = not (src.transform == Affine.identity() and not src.gcps[0])
    transform = georef.resolve_transform(src.transform if has_transform else None, src.shape, path)
    if transform is None:
        missing = "geotransform" + ("" if crs_wkt else " and no CRS")
        raise InputError(f"{path} is not georeferenced (it has no {missing}); give it a CRS and corner "
                         "coordinates first, e.g. gdal_translate -a_srs EPSG:32632 -a_ullr ULX ULY LRX LRY "
                         f"{path.name} dem.tif, or assign a cell size (--cell-size; --input-cell-size with "
                         "convert).")
    tags = {k: v for k, v in src.tags().items() if kept(k)}
    itemsize = np.dtype(src.dtypes[band - 1]).itemsize
    nodata = src.nodatavals[band - 1] if georef.nodata is None else georef.nodata
    return GdalHeader((src.height, src.width), itemsize, crs_wkt, transform, nodata, tags, src.count)


def write_bytes_per_cell(path: Path) -> int:
    """Peak bytes per cell of writing a heightfield to ``path`` beyond the heightfield itself:
    GDAL rasters are written in strips (0); EXR files whole, cast to float32 (4) with their
    nodata mask (1)."""
    return 5 if path.suffix.lower() == ".exr" else 0


def write_gdal(terrain: Terrain, path: Path, options: WriteOptions) -> None:
    """Write ``terrain`` to ``path`` in the format of its extension, atomically.

    GDAL writes under the output's own name into a temporary folder beside it, so that every
    name it derives (side files such as .hdr, .prj, .aux.xml; a GeoPackage's table) is the
    final one; the side files are then moved beside ``path`` and the raster renamed onto it
    (paths.atomic_path). Nothing is left behind should the write fail.

    GeoTIFF gets DEFLATE, floating-point predictor, 256² tiles and BIGTIFF when needed, or COG
    layout with ``options.cog``.
    """
    with staging_folder(path) as folder:
        staged = folder / path.name
        try:
            _write(terrain, staged, options)
        except _WRITE_ERRORS as exc:
            raise InputError(f"cannot write {path}: {_first_line(exc)}.") from None
        for side in folder.iterdir():
            if side != staged:
                place(side, path.with_name(side.name))
        with atomic_path(path) as tmp:
            os.replace(staged, tmp)


def check_gdal_writable(path: Path, options: WriteOptions) -> None:
    """Refuse, before any work, a GDAL output (``path`` has one of writable_extensions()) that
    could not be written: ``--cog`` on a non-GeoTIFF, a cell type the driver cannot hold, and
    creation options the driver does not know or whose value it does not allow. A 2 × 2 raster
    is written with the same options to a temporary folder to find out."""
    output_format(path, options.cog)
    rejected = _probe(path.suffix.lower(), options.dtype, options.cog,
                      tuple(sorted(options.creation_options.items())))
    if rejected:
        raise InputError(f"cannot write {path}: {rejected}.")


@functools.cache
def writable_extensions() -> tuple[str, ...]:
    """The extensions of FORMATS whose driver the bundled GDAL has."""
    with rasterio.Env() as env:
        drivers = env.drivers()
    return tuple(suffix for suffix, fmt in FORMATS.items() if fmt.driver in drivers)


def output_format(path: Path, cog: bool) -> Format:
    """The format that the extension of ``path`` (one of writable_extensions()) names: COG for a
    .tif with ``cog``."""
    suffix = path.suffix.lower()
    if cog and suffix not in (".tif", ".tiff"):
        raise InputError(f"--cog needs a .tif output, got {path}.")
    return _COG if cog else FORMATS[suffix]


@functools.cache
def _probe(suffix: str, dtype: str, cog: bool, creation_options: tuple[tuple[str, str], ...]) -> str:
    """Why a raster with these settings cannot be written ("" when it can)."""
    options = WriteOptions(dtype, cog, dict(creation_options))
    driver = output_format(Path(f"probe{suffix}"), cog).driver
    probe = Terrain(np.zeros((2, 2)), 1.0, 1.0, RioCRS.from_epsg(32632).to_wkt(),
                    Affine(1.0, 0.0, 500000.0, 0.0, -1.0, 5000000.0))
    with tempfile.TemporaryDirectory() as folder, _gdal_warnings() as warnings:
        try:
            _write(probe, Path(folder) / f"probe{suffix}", options)
        except _WRITE_ERRORS as exc:
            detail = _first_line(exc).replace(f"probe{suffix}: ", "")
            return f"GDAL's {driver} driver cannot write {dtype} cells{_with_co(options)} ({detail})"
    messages = [re.sub(r"^CPLE_\w+ in ", "", r.getMessage()).rstrip(".") for r in warnings.buffer]
    for key, value in options.creation_options.items():
        said = [m for m in messages if re.search(rf"\b{re.escape(key)}\b", m)]
        if said:
            return f"--co {key}={value} is not accepted by GDAL's {driver} driver ({said[0]})"
    return ""


def _with_co(options: WriteOptions) -> str:
    entries = [f"--co {k}={v}" for k, v in options.creation_options.items()]
    return f" with {', '.join(entries)}" if entries else ""


@contextlib.contextmanager
def _gdal_warnings() -> Iterator[BufferingHandler]:
    """Collect (in ``.buffer``) the GDAL warnings, which rasterio logs, issued inside the block."""
    handler = BufferingHandler(capacity=10_000)
    handler.setLevel(logging.WARNING)
    logger = logging.getLogger("rasterio._env")
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING)
    try:
        yield handler
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def _write(terrain: Terrain, path: Path, options: WriteOptions) -> None:
    """Write ``terrain`` to ``path`` with GDAL (raises GDAL's errors, and ValueError for a
    projection the format cannot hold)."""
    fmt = output_format(path, options.cog)
    _check_projection(fmt, terrain.crs_wkt)
    nodata = output_nodata(terrain)
    layout = {
        "height": terrain.shape[0],
        "width": terrain.shape[1],
        "count": 1,
        "dtype": options.dtype,
        "crs": RioCRS.from_wkt(terrain.crs_wkt) if terrain.crs_wkt else None,
        "transform": terrain.transform,
        "nodata": nodata,
    }
    creation = dict(fmt.defaults)
    if fmt.driver in ("GTiff", "COG") and np.issubdtype(np.dtype(options.dtype), np.integer):
        creation["PREDICTOR"] = "2"  # horizontal differencing: the floating-point one needs floats
    creation.update(options.creation_options)
    if not fmt.by_copy:
        with rasterio.open(path, "w", driver=fmt.driver, **layout, **creation) as dst:
            _fill(dst, terrain, nodata, options.dtype)
        return
    # formats GDAL writes only by copy: from a tiled GeoTIFF staged on disk beside the output
    staged = path.with_name(f".{path.name}.staged.tif")
    try:
        with rasterio.open(staged, "w", driver="GTiff", TILED="YES", BIGTIFF="IF_SAFER", **layout) as dst:
            _fill(dst, terrain, nodata, options.dtype)
        with rasterio.open(staged) as source:
            rasterio.shutil.copy(source, path, driver=fmt.driver, **creation)
        if fmt.driver == "netCDF":
            name_raster_variable(path, terrain.tags)
    finally:
        staged.unlink(missing_ok=True)


def _check_projection(fmt: Format, crs_wkt: str) -> None:
    """Raise ValueError if ``fmt`` cannot hold the map projection of ``crs_wkt``."""
    if fmt.projections is None or not crs_wkt:
        return
    operation = CRS.from_wkt(crs_wkt).coordinate_operation
    if operation is not None and operation.method_name not in fmt.projections:
        raise ValueError(f"the {fmt.driver} format cannot hold the projection '{operation.method_name}'; "
                         "write a .tif instead")


def _fill(dst: rasterio.io.DatasetWriter, terrain: Terrain, nodata: float | None, dtype: str) -> None:
    """Write the band strip by strip (NaN cells as ``nodata``, cast to ``dtype``), the kept
    tags and the unit into an open dataset."""
    rows, cols = terrain.shape
    for first, end in strips(rows, cols):
        strip = terrain.elevation[first:end]
        if nodata is not None:
            strip = np.where(np.isfinite(strip), strip, nodata)
        dst.write(strip.astype(dtype), 1, window=Window(0, first, cols, end - first))
    dst.update_tags(**{k: v for k, v in terrain.tags.items() if kept(k)})
    if "UNIT" in terrain.tags:
        dst.units = (terrain.tags["UNIT"],)


def output_nodata(terrain: Terrain) -> float | None:
    """The nodata value to write: the terrain's, else −9999 when it has nodata cells.

    Should a valid elevation equal that value in float32, NaN is used instead so that no
    valid cell is ever read back as nodata.
    """
    candidate = terrain.nodata
    rows, cols = terrain.shape
    elevation = terrain.elevation
    if candidate is None:
        if all(np.isfinite(elevation[first:end]).all() for first, end in strips(rows, cols)):
            return None
        candidate = -9999.0
    candidate = float(candidate)
    written = np.float32(candidate)
    # NaN cells never equal it: only valid cells can clash
    clash = any(np.any(elevation[first:end].astype(np.float32) == written)
                for first, end in strips(rows, cols))
    return float("nan") if clash else candidate


def _corrupt(path: Path, exc: Exception) -> InputError:
    """The error for a raster GDAL recognises but cannot read through (the cause GDAL gives
    for "Read failed" is in ``exc.__cause__``)."""
    cause = exc.__cause__ or exc
    return InputError(f"{path} is truncated or corrupt ({_first_line(cause)}).")


def _first_line(exc: Exception) -> str:
    return str(exc).strip().splitlines()[0].rstrip(".") if str(exc).strip() else type(exc).__name__
