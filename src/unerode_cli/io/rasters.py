"""Read and write heightfields by file extension: ``.exr`` via OpenEXR, anything else via GDAL."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.errors import InputError
from unerode_cli.io.exr_io import read_exr, write_exr
from unerode_cli.io.gdal_io import (
    WriteOptions,
    check_gdal_writable,
    read_gdal,
    writable_extensions,
    write_gdal,
)
from unerode_cli.io.paths import atomic_path
from unerode_cli.io.terrain import Terrain


def is_exr(path: Path) -> bool:
    return path.suffix.lower() == ".exr"


def read_terrain(path: Path, band: int | None = None, channel: str | None = None) -> Terrain:
    """Read a heightfield (metres) from a GDAL raster or an OpenEXR file; never writes to it."""
    if not path.exists():
        raise InputError(f"input {path} does not exist.")
    if path.is_dir():
        raise InputError(f"input {path} is a folder, not a raster file.")
    if is_exr(path):
        return read_exr(path, channel)
    return read_gdal(path, band)


def check_writable(path: Path, options: WriteOptions) -> None:
    """Refuse, before any work, a heightfield output that could not be written: no extension
    or an unknown one, EXR with another dtype than float32 or with --cog or --co, --cog on a
    non-GeoTIFF, a dtype the format cannot hold, creation options its driver does not know or
    whose value it does not allow."""
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
