"""What `compare-terraces` reads: the snapshots (files, folders or globs) and their ages, the
river (a line file or the main stem of the present DEM), the observed terraces placed along it,
and the riverbed of each snapshot."""

from __future__ import annotations

import glob
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from unerode_cli.analysis.river import (
    RiverPath,
    auto_river,
    bed_profile,
    downstream_first,
    path_from_vertices,
)
from unerode_cli.analysis.terraces import Terrace
from unerode_cli.errors import InputError
from unerode_cli.hydro import outlet_mask
from unerode_cli.io.grid_rasters import read_on_grid
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.observation_files import TerraceRow
from unerode_cli.io.river_files import read_river_line
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.outputs import AGE_TAG

RASTER_SUFFIXES = (".tif", ".tiff", ".exr", ".vrt", ".img", ".asc")
_AGE_IN_NAME = re.compile(r"_(\d+(?:\.\d+)?)ka$")


def expanded(entries: Sequence[str]) -> tuple[Path, ...]:
    """Snapshot entries: files, folders, or glob patterns (quoted so the shell leaves them)."""
    paths: list[Path] = []
    for entry in entries:
        matches = sorted(glob.glob(entry)) if glob.has_magic(entry) else [entry]
        paths += [Path(match) for match in matches] or [Path(entry)]
    return tuple(paths)


def parse_point(text: str | None) -> tuple[float, float] | None:
    """``"X,Y"`` (the DEM's CRS) → (x, y); None stays None."""
    if text is None:
        return None
    try:
        x, y = (float(part) for part in text.split(","))
    except ValueError:
        raise InputError(f"--river-start expects X,Y in the DEM's CRS, got '{text}'.") from None
    return x, y


def snapshot_files(entries: tuple[Path, ...], present: Path) -> list[Path]:
    """The snapshot rasters: files as given, folders expanded to their rasters (the present
    DEM excluded), sorted by name."""
    files: list[Path] = []
    for entry in entries:
        if entry.is_dir():
            found = sorted(p for p in entry.iterdir() if p.suffix.lower() in RASTER_SUFFIXES
                           and not p.name.startswith(".") and p.resolve() != present.resolve())
            if not found:
                raise InputError(f"the snapshot folder {entry} holds no raster.")
            files += found
        elif entry.exists():
            files.append(entry)
        else:
            raise InputError(f"the snapshot {entry} does not exist.")
    return files


def snapshot_age(layer: Terrain, path: Path) -> float | None:
    """Age (ka) of a snapshot: its UNERODE_AGE_KA tag, else a name ending in ``_<age>ka``."""
    tag = layer.tags.get(AGE_TAG)
    if tag is not None:
        try:
            return float(tag)
        except ValueError:
            raise InputError(f"snapshot {path} has a malformed {AGE_TAG} tag '{tag}'.") from None
    match = _AGE_IN_NAME.search(path.stem)
    return float(match.group(1)) if match else None


def _cell_of(terrain: Terrain, x: float, y: float) -> tuple[float, float]:
    """(row, col) cell coordinates of the CRS point (x, y); cell centres are integers."""
    col, row = ~terrain.transform @ (x, y)
    return row - 0.5, col - 0.5


def _inside(terrain: Terrain, row: float, col: float) -> bool:
    ny, nx = terrain.shape
    return -0.5 <= row <= ny - 0.5 and -0.5 <= col <= nx - 0.5


def river_from_line(line: Path, present: Terrain, search_radius: float) -> RiverPath:
    """The river along the vertices of ``line`` (the DEM's CRS), from its mouth up (the end
    whose bed is lower comes first); ``search_radius`` (m) as in :func:`bed_profile`."""
    grid = present.grid
    xs, ys = read_river_line(line)
    rows, cols = _cell_of(present, xs, ys)
    outside = ~(((rows >= -0.5) & (rows <= grid.shape[0] - 0.5))
                & ((cols >= -0.5) & (cols <= grid.shape[1] - 0.5)))
    if outside.any():
        k = int(np.argmax(outside))
        raise InputError(f"vertex {k + 1} of the river line ({xs[k]:g}, {ys[k]:g}) lies outside the DEM.")
    try:
        path = path_from_vertices(rows, cols, grid.dx, grid.dy, min(grid.dx, grid.dy), f"line {line}")
    except ValueError as exc:
        raise InputError(f"{exc} ({line}).") from None
    return downstream_first(path, bed_profile(present.elevation, path, grid.dx, grid.dy, search_radius))


def main_river(present: Terrain, start: tuple[float, float] | None, outlets: str, sea_level: float | None,
               min_area_fraction: float) -> RiverPath:
    """The main channel by steepest descent: up from ``start`` (x, y in the DEM's CRS), or up
    the main stem of the largest catchment until its donors drain less than
    ``min_area_fraction`` of it; water leaves through ``outlets`` and below ``sea_level`` (m)."""
    cell = None
    if start is not None:
        row, col = _cell_of(present, *start)
        if not _inside(present, row, col):
            raise InputError(f"the river start {start} lies outside the DEM.")
        cell = (int(round(row)), int(round(col)))
    try:
        mask = outlet_mask(present.grid, outlets, elevation=present.elevation, sea_level=sea_level)
        return auto_river(present.elevation, present.grid, mask, cell, min_area_fraction)
    except ValueError as exc:
        raise InputError(f"{exc}.") from None


def placed_terraces(rows: list[TerraceRow], present: Terrain, river: RiverPath,
                    source: Path) -> list[Terrace]:
    """The observed terraces of ``source`` with their chainage (m) along the river: given, or
    that of the river's point nearest to their x, y (with their distance to it, m)."""
    terraces = []
    for row in rows:
        chainage, distance = row.chainage_m, None
        if row.x is not None:
            r, c = _cell_of(present, row.x, row.y)
            if not _inside(present, r, c):
                raise InputError(
                    f"{source}, line {row.line}: the point ({row.x:g}, {row.y:g}) lies outside the DEM."
                )
            chainage, distance = river.locate(r, c, present.dx, present.dy)
        elif chainage is not None and chainage > river.length:
            raise InputError(f"{source}, line {row.line}: chainage {chainage:g} m is beyond the river's "
                             f"end ({river.length:.6g} m).")
        terraces.append(Terrace(row.line, row.age_ka, row.height_m, row.uncertainty_m, row.name,
                                chainage, distance))
    return terraces


def snapshot_beds(files: list[Path], present: Terrain, river: RiverPath, search_radius: float,
                  georef: InputGeoref | None = None) -> tuple[list[tuple[float, np.ndarray]], list[dict]]:
    """(age ka, riverbed elevations m along the river) of each snapshot, read one at a time on
    the present DEM's grid with what ``georef`` assigns (``--crs``, ``--cell-size``,
    ``--nodata``), and the snapshots used ({path, age_ka}, oldest last)."""
    beds, listed = [], []
    for path in files:
        layer = read_on_grid(path, present, "snapshot", georef)
        age = snapshot_age(layer, path)
        if age is None:
            raise InputError(f"snapshot {path} has no age: it lacks the {AGE_TAG} tag of climate-run "
                             "and its name does not end in _<age>ka.")
        bed = bed_profile(layer.elevation, river, present.dx, present.dy, search_radius)
        if any(age == seen and np.array_equal(bed, other, equal_nan=True) for seen, other in beds):
            continue  # climate-run's final output repeats the snapshot at its age
        beds.append((age, bed))
        listed.append({"path": str(path), "age_ka": age})
    return beds, sorted(listed, key=lambda item: item["age_ka"])
