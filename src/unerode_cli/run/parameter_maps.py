"""Parameters given as a number or as a raster on the DEM's grid (DESIGN §4)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import read_on_grid
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes.parameters import ParamSpec


def resolve(spec: ParamSpec, value: str | float, terrain: Terrain,
            files: str = "a raster") -> float | np.ndarray:
    """A parameter value from a number or a raster path, validated against ``spec``.

    Raster values outside the domain (nodata) are ignored; inside it they must be finite. A
    raster without a CRS or geotransform takes the DEM's (with what ``--crs`` and
    ``--cell-size`` gave the DEM); one with another CRS, grid or shape is refused.
    A text that is neither a number nor the path of an existing file is refused as such
    (``files`` names the files the parameter also takes, for that sentence).
    """
    number = _as_number(value)
    if number is not None:
        resolved: float | np.ndarray = number
    elif not spec.raster:
        raise InputError(f"parameter {spec.name} must be a number, got '{value}'.")
    else:
        path = Path(str(value))
        if not _exists(path):
            flag = f"--{(spec.symbol or spec.name).replace('_', '-')}"
            raise InputError(f"parameter {spec.name} ({flag}) is '{value}', neither a number nor {files} "
                             "that exists.")
        georef = InputGeoref.on_grid(terrain.crs_wkt, terrain.transform)
        layer = read_on_grid(path, terrain, f"parameter {spec.name}", georef).elevation
        valid = ~terrain.nodata_mask
        if not np.isfinite(layer[valid]).all():
            raise InputError(f"parameter raster {value} has nodata inside the DEM's domain.")
        resolved = np.where(valid, layer, 0.0 if spec.minimum is None else spec.minimum)
    try:
        spec.check(resolved)
    except ValueError as exc:
        raise InputError(f"{exc}.") from None
    return resolved


def _as_number(value: str | float) -> float | None:
    try:
        return float(value)
    except ValueError:
        return None


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except (OSError, ValueError):  # a name too long, a NUL character
        return False
