"""Parameters given as a number or as a raster on the DEM's grid (DESIGN §4)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pyproj import CRS

from unerode_cli.errors import InputError
from unerode_cli.processes.parameters import ParamSpec
from unerode_cli.raster.io import read_terrain
from unerode_cli.raster.terrain import Terrain


def same_crs(a_wkt: str, b_wkt: str) -> bool:
    """Whether two WKT strings name the same CRS (both empty counts as the same)."""
    if not a_wkt or not b_wkt:
        return a_wkt == b_wkt
    return CRS.from_wkt(a_wkt) == CRS.from_wkt(b_wkt)


def load_on_grid(path: Path, terrain: Terrain, what: str) -> np.ndarray:
    """Read a raster that must lie on ``terrain``'s grid (shape, transform and CRS checked)."""
    return read_on_grid(path, terrain, what).elevation


def read_on_grid(path: Path, terrain: Terrain, what: str) -> Terrain:
    """Read a raster, with its tags, that must lie on ``terrain``'s grid (shape, transform and
    CRS checked; ``what`` names it in messages)."""
    layer = read_terrain(path)
    if layer.shape != terrain.shape:
        raise InputError(
            f"{what} raster {path} has {layer.shape[0]} × {layer.shape[1]} cells but the DEM has "
            f"{terrain.shape[0]} × {terrain.shape[1]}."
        )
    if not layer.transform.almost_equals(terrain.transform, precision=1e-9 * max(terrain.dx, 1)):
        raise InputError(f"{what} raster {path} is not aligned with the DEM (different transform).")
    if not same_crs(layer.crs_wkt, terrain.crs_wkt):
        raise InputError(f"{what} raster {path} is not in the DEM's CRS.")
    return layer


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
