"""What a coarse run leaves for the runs nested in it (000 §6.3.1, "two maps at two different
scales"): a folder ``OUT_fluxes/`` beside the run's output holding, at each age it kept (ka),
three float32 GeoTIFFs on the coarse grid: ``elevation_<age>ka.tif`` (m),
``discharge_<age>ka.tif`` (water discharge Q, m³/y) and ``sediment_flux_<age>ka.tif`` (the
sediment flux Q_s leaving each cell, m³/y).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.grid_rasters import check_on_grid
from unerode_cli.io.paths import check_output
from unerode_cli.io.rasters import read_terrain, write_terrain
from unerode_cli.io.terrain import Terrain

FIELDS = ("elevation", "discharge", "sediment_flux")
_NAME = re.compile(r"^(elevation|discharge|sediment_flux)_(-?[0-9.]+(?:e[-+]?[0-9]+)?)ka\.tif$")


def fluxes_folder(output: Path) -> Path:
    """``past.tif`` → ``past_fluxes``: where a run's nesting rasters go."""
    return output.with_name(f"{output.stem}_fluxes")


def coarse_run_folder(path: Path) -> Path:
    """The nesting folder that ``--inflow-from PATH`` names: PATH itself when a folder, else the
    ``_fluxes`` folder beside the coarse run's output PATH."""
    return path if path.is_dir() else fluxes_folder(path)


def field_path(folder: Path, name: str, age_ka: float) -> Path:
    return folder / f"{name}_{age_ka:g}ka.tif"


def check_fluxes_folder(folder: Path, ages_ka: list[float], overwrite: bool) -> None:
    """Clear the nesting rasters of a run before any work: the folder is not a file, its
    parent exists, and none of the rasters exists (without ``overwrite``)."""
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{folder} is a file; the nesting rasters of --write-fluxes go in a folder "
                         "of that name.")
    if not folder.parent.exists():
        raise InputError(f"the folder of output {folder} does not exist.")
    if folder.is_dir():
        for age in ages_ka:
            for name in FIELDS:
                check_output(field_path(folder, name, age), overwrite)


def write_state(folder: Path, terrain: Terrain, age_ka: float, discharge: np.ndarray,
                sediment_flux: np.ndarray, tags: dict[str, str]) -> None:
    """Write the three nesting rasters of ``age_ka`` (``terrain`` holds the elevation), each
    atomically, with ``tags`` (e.g. the age and sea level)."""
    folder.mkdir(exist_ok=True)
    for name, values in zip(FIELDS, (terrain.elevation, discharge, sediment_flux), strict=True):
        layer = terrain.with_elevation(values)
        layer.tags = dict(tags)
        write_terrain(layer, field_path(folder, name, age_ka))


@dataclass(frozen=True)
class CoarseState:
    """The coarse run at one age: elevation (m, NaN on nodata, with the coarse grid), Q and Q_s
    (m³/y, float64[ny, nx])."""

    age_ka: float
    terrain: Terrain
    discharge: np.ndarray
    sediment_flux: np.ndarray


@dataclass(frozen=True)
class CoarseRun:
    """The nesting rasters of a coarse run: their folder and ages (ka, increasing)."""

    folder: Path
    ages_ka: tuple[float, ...]

    def state(self, age_ka: float) -> CoarseState:
        """Read the three rasters of one of ``ages_ka``, checked to lie on one grid."""
        terrain = read_terrain(field_path(self.folder, "elevation", age_ka))
        fields = []
        for name in FIELDS[1:]:
            path = field_path(self.folder, name, age_ka)
            layer = read_terrain(path)
            check_on_grid(layer.shape, layer.transform, layer.crs_wkt, terrain, path,
                          f"the coarse run's {name.replace('_', ' ')}")
            fields.append(np.nan_to_num(layer.elevation, nan=0.0))
        return CoarseState(age_ka, terrain, *fields)


def read_coarse_run(path: Path) -> CoarseRun:
    """The coarse run of ``--inflow-from PATH``: its ``_fluxes`` folder, or its output raster
    (the folder beside it); every age must have its three rasters."""
    folder = coarse_run_folder(path)
    if not path.exists():
        raise InputError(f"--inflow-from {path} does not exist.")
    if not folder.is_dir():
        raise InputError(f"{path} has no nesting rasters beside it ({folder.name}/): run the coarse "
                         "climate-run with --write-fluxes.")
    found: dict[float, set[str]] = {}
    for entry in folder.iterdir():
        match = _NAME.match(entry.name)
        if match:
            found.setdefault(float(match.group(2)), set()).add(match.group(1))
    if not found:
        raise InputError(f"the folder {folder} holds no nesting rasters (elevation_<age>ka.tif, "
                         "discharge_…, sediment_flux_…) of a climate-run with --write-fluxes.")
    for age, names in sorted(found.items()):
        missing = [name for name in FIELDS if name not in names]
        if missing:
            raise InputError(f"the folder {folder} lacks {missing[0]}_{age:g}ka.tif.")
    return CoarseRun(folder, tuple(sorted(found)))
