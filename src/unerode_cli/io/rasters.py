"""Read and write heightfields by file extension: ``.exr`` via OpenEXR, anything else via GDAL."""

from __future__ import annotations

from pathlib import Path

from unerode_cli.errors import InputError
from unerode_cli.io.exr_io import read_exr, write_exr
from unerode_cli.io.gdal_io import WriteOptions, read_gdal, write_gdal
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


def write_terrain(terrain: Terrain, path: Path, options: WriteOptions | None = None) -> None:
    """Write atomically (temporary file beside ``path``, then rename)."""
    options = options or WriteOptions()
    if is_exr(path):
        if options.dtype != "float32" or options.cog or options.creation_options:
            raise InputError("EXR outputs are always float32 ZIP; --dtype, --cog and --co do not apply.")
        writer = write_exr
    else:
        def writer(t: Terrain, p: Path) -> None:
            write_gdal(t, p, options)
    with atomic_path(path) as tmp:
        writer(terrain, tmp)
