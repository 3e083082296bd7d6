"""Reading an inflow table: rivers entering the map through its edges (000 §6.3.1).

A CSV with a header ``x,y,discharge_m3_per_y,sediment_m3_per_y[,age_ka]``: one row per river
(per river and age with ``age_ka``), its point in the DEM's CRS, its water discharge and its
sediment flux (m³/y). Each point is snapped to the nearest valid cell, which must lie within
one cell of the map's edge or of nodata and must not be an outlet; points on the same cell add
up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage

from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import table_number, table_rows
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes.inflow import InflowHistory

COLUMNS = ("x", "y", "discharge_m3_per_y", "sediment_m3_per_y")
#: Optional column: the age (ka) of the row, for an inflow that changes through time.
AGE_COLUMN = "age_ka"


@dataclass
class _River:
    """The rows of one river (one point) of an inflow table."""

    cell: int
    first_line: int
    ages: list[float] = field(default_factory=list)
    discharge: list[float] = field(default_factory=list)
    sediment: list[float] = field(default_factory=list)


def read_inflow(path: Path, terrain: Terrain, outlets: np.ndarray) -> InflowHistory:
    """The inflow of the table at ``path`` on the grid of ``terrain`` (m³/y per cell).

    Without an ``age_ka`` column the inflow is constant; with it, the rows of each river (the
    same x, y) give its discharge and sediment flux at their ages, linear in age between them,
    and every river must be given over the same span of ages.

    Args:
        path: the CSV table (columns ``COLUMNS``, optionally ``age_ka``).
        terrain: the DEM whose CRS the points are in.
        outlets: bool[ny, nx] the run's base-level cells at its start; an inflow there would
            leave at once.

    Raises:
        InputError: a bad table or one without rows, or a point outside the map, snapped to a
            cell more than one cell from the edge and from nodata, or snapped to an outlet
            (naming the line); with ages, a row without one, a river given twice at one age or
            over a shorter span than the others.
    """
    near_edge = _near_edge(terrain.nodata_mask)
    nearest, rivers, timed = None, {}, None
    for line, row in table_rows(path, "inflow", (*COLUMNS, AGE_COLUMN), COLUMNS):
        if timed is None:
            timed = AGE_COLUMN in row
        x, y, q, qs = (table_number(row, name, path, line, minimum) for name, minimum in
                       zip(COLUMNS, (None, None, 0.0, 0.0), strict=True))
        age = table_number(row, AGE_COLUMN, path, line) if timed else 0.0
        if age is None:
            raise InputError(f"{path}, line {line}: {AGE_COLUMN} is empty; an inflow through time "
                             "gives an age on every row.")
        river = rivers.get((x, y))
        if river is None:
            r, c = _cell_of(terrain, x, y, path, line)
            if terrain.nodata_mask[r, c]:
                if nearest is None:
                    nearest = _nearest_valid(terrain)
                r, c = int(nearest[0][r, c]), int(nearest[1][r, c])
            _check_entry(path, line, x, y, r, c, near_edge, outlets)
            river = rivers[(x, y)] = _River(r * terrain.shape[1] + c, line)
        if age in river.ages:
            raise InputError(f"{path}, line {line}: the river at ({x:.12g}, {y:.12g}) is given twice "
                             + (f"at {age:g} ka." if timed else "; give each river once."))
        river.ages.append(age)
        river.discharge.append(q)
        river.sediment.append(qs)
    if not rivers:
        raise InputError(f"the inflow file {path} has no row.")
    return _history(path, terrain.shape, list(rivers.items()))


def _check_entry(path: Path, line: int, x: float, y: float, r: int, c: int, near_edge: np.ndarray,
                 outlets: np.ndarray) -> None:
    """Refuse a river whose cell (r, c) is not by the edge or is an outlet."""
    where = (f"{path}, line {line}: the point ({x:.12g}, {y:.12g}) snaps to the cell at row {r}, "
             f"column {c}")
    if not near_edge[r, c]:
        raise InputError(f"{where}, more than one cell from the map's edge and from nodata; "
                         "a river enters through the edges.")
    if outlets[r, c]:
        raise InputError(f"{where}, an outlet where the inflow would leave at once; move it one "
                         "cell inward or leave that edge out of --outlets.")


def _history(path: Path, shape: tuple[int, int],
             rivers: list[tuple[tuple[float, float], _River]]) -> InflowHistory:
    """Every river on the union of the table's ages (each river linear in age)."""
    ages = np.unique(np.concatenate([river.ages for _, river in rivers]))
    discharge, sediment = [], []
    for (x, y), river in rivers:
        own = np.asarray(river.ages)
        if own.min() > ages[0] or own.max() < ages[-1]:
            raise InputError(f"{path}, line {river.first_line}: the river at ({x:.12g}, {y:.12g}) is "
                             f"given from {own.min():g} to {own.max():g} ka, the table from {ages[0]:g} "
                             f"to {ages[-1]:g} ka; give every river over the same span.")
        order = np.argsort(own)
        discharge.append(np.interp(ages, own[order], np.asarray(river.discharge)[order]))
        sediment.append(np.interp(ages, own[order], np.asarray(river.sediment)[order]))
    cells = np.array([river.cell for _, river in rivers], dtype=np.int64)
    return InflowHistory(shape, cells, ages, np.stack(discharge, axis=1), np.stack(sediment, axis=1))


def _cell_of(terrain: Terrain, x: float, y: float, path: Path, line: int) -> tuple[int, int]:
    """(row, column) of the cell holding the point (x, y); InputError when off the map."""
    col, row = ~terrain.transform @ (x, y)
    ny, nx = terrain.shape
    if not (0.0 <= row < ny and 0.0 <= col < nx):
        raise InputError(f"{path}, line {line}: the point ({x:.12g}, {y:.12g}) is outside the map.")
    return min(math.floor(row), ny - 1), min(math.floor(col), nx - 1)


def _near_edge(nodata: np.ndarray) -> np.ndarray:
    """bool[ny, nx]: cells on the map's edge or of nodata, or next to one (8 neighbours)."""
    border = np.ones(nodata.shape, dtype=bool)
    border[1:-1, 1:-1] = False
    return ndimage.binary_dilation(border | nodata, structure=np.ones((3, 3), dtype=bool))


def _nearest_valid(terrain: Terrain) -> np.ndarray:
    """int[2, ny, nx]: (row, column) of the nearest valid cell to every cell (in metres)."""
    return ndimage.distance_transform_edt(terrain.nodata_mask, sampling=(terrain.dy, terrain.dx),
                                          return_distances=False, return_indices=True)
