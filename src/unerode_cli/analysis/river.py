"""A river as a line of sample points on the grid, with its chainage and bed profile.

Positions are in *cell coordinates*: the centre of cell (r, c) is (row, col) = (r, c), row 0
north. Chainage is the distance along the river from its downstream end (m), so it grows
upstream; the first sample is the downstream end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.hydro import drainage_area, route


@dataclass(frozen=True)
class RiverPath:
    """Sample points along a river, downstream end first.

    Attributes:
        rows, cols: float64[k] cell coordinates of the samples.
        chainage: float64[k] distance along the river from the downstream end (m).
        source: how the line was obtained (for reports).
    """

    rows: np.ndarray
    cols: np.ndarray
    chainage: np.ndarray
    source: str

    @property
    def length(self) -> float:
        """Length of the river line (m)."""
        return float(self.chainage[-1])

    def reversed(self) -> RiverPath:
        """The same line, walked from the other end."""
        rows, cols = self.rows[::-1].copy(), self.cols[::-1].copy()
        return RiverPath(rows, cols, self.length - self.chainage[::-1], self.source)

    def locate(self, row: float, col: float, dx: float, dy: float) -> tuple[float, float]:
        """Chainage (m) of the sample nearest to the point (row, col) and its distance (m)."""
        distance = np.hypot((self.rows - row) * dy, (self.cols - col) * dx)
        nearest = int(np.argmin(distance))
        return float(self.chainage[nearest]), float(distance[nearest])


def _chainage(rows: np.ndarray, cols: np.ndarray, dx: float, dy: float) -> np.ndarray:
    steps = np.hypot(np.diff(rows) * dy, np.diff(cols) * dx)
    return np.concatenate(([0.0], np.cumsum(steps)))


def path_from_cells(cells: np.ndarray, shape: tuple[int, int], dx: float, dy: float,
                    source: str) -> RiverPath:
    """A river through the centres of the flat cell indices ``cells`` (downstream first)."""
    rows, cols = np.divmod(np.asarray(cells, dtype=np.int64), shape[1])
    rows, cols = rows.astype(np.float64), cols.astype(np.float64)
    return RiverPath(rows, cols, _chainage(rows, cols, dx, dy), source)


def path_from_vertices(rows: np.ndarray, cols: np.ndarray, dx: float, dy: float,
                       spacing: float, source: str) -> RiverPath:
    """A polyline given by its vertices (cell coordinates), resampled every ``spacing`` metres
    along its length (vertices in the given order; see ``downstream_first``)."""
    rows, cols = np.asarray(rows, dtype=np.float64), np.asarray(cols, dtype=np.float64)
    if rows.size < 2:
        raise ValueError("a river line needs at least two vertices")
    along = _chainage(rows, cols, dx, dy)
    if along[-1] <= 0.0:
        raise ValueError("the river line has zero length")
    count = max(2, int(np.ceil(along[-1] / spacing)) + 1)
    chainage = np.linspace(0.0, along[-1], count)
    return RiverPath(np.interp(chainage, along, rows), np.interp(chainage, along, cols), chainage, source)


def downstream_first(path: RiverPath, present_bed: np.ndarray) -> RiverPath:
    """``path`` oriented so that its first sample is its lower end on the present bed profile
    (m, one value per sample); a river drawn from source to mouth is turned round."""
    finite = np.flatnonzero(np.isfinite(present_bed))
    if finite.size >= 2 and present_bed[finite[0]] > present_bed[finite[-1]]:
        return path.reversed()
    return path


def auto_river(
    elevation: np.ndarray,
    grid: Grid,
    outlets: np.ndarray,
    start: tuple[int, int] | None = None,
    min_area_fraction: float = 0.01,
) -> RiverPath:
    """The main channel by steepest descent (D8 on the priority-flooded surface).

    From ``start`` (row, col), the river is the steepest-descent path down to an outlet.
    Without ``start`` it is traced up from the outlet of the largest catchment, always into the
    donor of largest drainage area, until the donors drain less than ``min_area_fraction`` of
    that catchment. Either way the first sample is the downstream end.
    """
    from unerode_cli.analysis.river_kernels import trace_downstream, trace_upstream

    routing = route(elevation, grid, outlets, "d8")
    receivers = routing.receivers().ravel()
    ny, nx = grid.shape
    if start is not None:
        row, col = start
        if not (0 <= row < ny and 0 <= col < nx) or not grid.valid[row, col]:
            raise ValueError(f"the river start (row {row}, col {col}) is not a valid cell of the DEM")
        cells = trace_downstream(receivers, row * nx + col)[::-1]
        source = f"auto: steepest descent from row {row}, col {col}"
    else:
        area = drainage_area(routing).ravel()
        mouth = int(np.argmax(np.where(routing.outlets.ravel(), area, -1.0)))
        cells = trace_upstream(receivers, area, nx, mouth, min_area_fraction * area[mouth])
        source = f"auto: main stem of the largest catchment (down to {min_area_fraction:g} of its area)"
    if cells.size < 2:
        raise ValueError("the automatic river is a single cell: choose another start point")
    return path_from_cells(cells, grid.shape, grid.dx, grid.dy, source)


def bed_profile(elevation: np.ndarray, path: RiverPath, dx: float, dy: float,
                radius: float = 0.0) -> np.ndarray:
    """Riverbed elevation (m) at each sample of ``path``: the lowest valid cell whose centre
    lies within ``radius`` metres of the sample, the cell containing the sample always
    included (``radius`` 0: that cell alone). NaN where every such cell is nodata.

    A river line drawn on the present DEM rarely follows the bed of a past one cell for cell;
    a radius of a few cells finds the past bed beside it."""
    ny, nx = elevation.shape
    rows = np.clip(np.rint(path.rows).astype(np.int64), 0, ny - 1)
    cols = np.clip(np.rint(path.cols).astype(np.int64), 0, nx - 1)
    # Offsets beyond the grid's own extent reach no cell: the search stops at the grid's size.
    reach_r = int(min(np.ceil(radius / dy), ny - 1)) if np.isfinite(radius) else ny - 1
    reach_c = int(min(np.ceil(radius / dx), nx - 1)) if np.isfinite(radius) else nx - 1
    bed = elevation[rows, cols].astype(np.float64)
    for dr in range(-reach_r, reach_r + 1):
        for dc in range(-reach_c, reach_c + 1):
            if (dr or dc) and np.hypot(dr * dy, dc * dx) <= radius:
                r, c = rows + dr, cols + dc
                inside = (r >= 0) & (r < ny) & (c >= 0) & (c < nx)
                values = np.full(bed.shape, np.nan)
                values[inside] = elevation[r[inside], c[inside]]
                bed = np.fmin(bed, values)
    return bed
