"""Parameters given as a number or as a raster on the DEM's grid (DESIGN §4)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import load_on_grid
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes.parameters import ParamSpec


def resolve(spec: ParamSpec, value: str | float, terrain: Terrain) -> float | np.ndarray:
    """A parameter value from a number or a raster path, validated against ``spec``.

    Raster values outside the domain (nodata) are ignored; inside it they must be finite.
    """
    number = _as_number(value)
    if number is not None:
        resolved: float | np.ndarray = number
    elif not spec.raster:
        raise InputError(f"parameter {spec.name} must be a number, got '{value}'.")
    else:
        layer = load_on_grid(Path(str(value)), terrain, f"parameter {spec.name}")
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
