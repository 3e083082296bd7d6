"""Reading an inflow table: rivers entering the map through its edges (000 §6.3.1).

A CSV with a header ``x,y,discharge_m3_per_y,sediment_m3_per_y``: one row per river, its
point in the DEM's CRS, its water discharge and its sediment flux (m³/y). Each point is
snapped to the nearest valid cell, which must lie within one cell of the map's edge or of
nodata and must not be an outlet; points on the same cell add up.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy import ndimage

from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import table_number, table_rows
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes.fluvial import Inflow

COLUMNS = ("x", "y", "discharge_m3_per_y", "sediment_m3_per_y")
#: An inflow that changes through time: not supported (one constant inflow per river).
AGE_COLUMN = "age_ka"


def read_inflow(path: Path, terrain: Terrain, outlets: np.ndarray) -> Inflow:
    """The inflow of the table at ``path`` on the grid of ``terrain`` (m³/y per cell).

    Args:
        path: the CSV table (columns ``COLUMNS``).
        terrain: the DEM whose CRS the points are in.
        outlets: bool[ny, nx] the run's base-level cells at its start; an inflow there would
            leave at once.

    Raises:
        InputError: a bad table or one without rows, or a point outside the map, snapped to a
            cell more than one cell from the edge and from nodata, or snapped to an outlet
            (naming the line).
    """
    shape = terrain.shape
    discharge = np.zeros(shape, dtype=np.float64)
    sediment = np.zeros(shape, dtype=np.float64)
    near_edge = _near_edge(terrain.nodata_mask)
    nearest, rivers = None, 0
    for line, row in table_rows(path, "inflow", (*COLUMNS, AGE_COLUMN), COLUMNS):
        if AGE_COLUMN in row:
            raise InputError(f"{path}, line {line}: an inflow through time ({AGE_COLUMN}) is not "
                             "supported; give one constant inflow per river.")
        x, y, q, qs = (table_number(row, name, path, line, minimum) for name, minimum in
                       zip(COLUMNS, (None, None, 0.0, 0.0), strict=True))
        r, c = _cell_of(terrain, x, y, path, line)
        if terrain.nodata_mask[r, c]:
            if nearest is None:
                nearest = _nearest_valid(terrain)
            r, c = int(nearest[0][r, c]), int(nearest[1][r, c])
        where = (f"{path}, line {line}: the point ({x:.12g}, {y:.12g}) snaps to the cell at row {r}, "
                 f"column {c}")
        if not near_edge[r, c]:
            raise InputError(f"{where}, more than one cell from the map's edge and from nodata; "
                             "a river enters through the edges.")
        if outlets[r, c]:
            raise InputError(f"{where}, an outlet where the inflow would leave at once; move it one "
                             "cell inward or leave that edge out of --outlets.")
        discharge[r, c] += q
        sediment[r, c] += qs
        rivers += 1
    if rivers == 0:
        raise InputError(f"the inflow file {path} has no row.")
    return Inflow(discharge, sediment)


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
