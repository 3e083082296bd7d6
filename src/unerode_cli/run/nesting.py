"""Two maps at two scales (000 §6.3.1): a fine run nested in a coarse run over a larger area
reads off the coarse run, at each of its kept ages, the water and sediment that cross into the
fine map and the level of the surface along the fine map's boundary.

What crosses: the coarse surface is routed again with multiple flow directions (000 Eq. 6,
every edge and nodata border an outlet); each coarse cell just outside the fine map's
footprint (the coarse cells whose centres fall on valid fine cells) sends the fraction of its
discharge Q and of its leaving sediment flux Q_s that goes to a footprint cell into the fine
map, at the fine cell under the midpoint of the two centres when that cell is neither nodata
nor an outlet of the fine run; else (it is usually a boundary node, an outlet) at its lowest
neighbour that is neither, the cell the water crossing there runs down to on the fine surface
(a bank cell beside the channel would send it straight back into the boundary outlets); else
at the nearest such cell. Levels: the coarse elevation, interpolated bilinearly at the centres of
the fine boundary nodes. Between kept ages, both are linear in age.

Where the water leaves (the fine run's outlets when it is given none, :func:`crossing_outlets`):
the same routing's outflow crossings, at every coarse age the fine run's span needs. A crossing
is a footprint cell that sends a share of a positive Q to a coarse cell outside the footprint
of whose water at least :data:`LEAVING_SHARE` never comes back into the footprint downstream
(water that leaves and re-enters, e.g. through a pit of the coarse surface just outside the
edge, does not count), or a footprint cell that is itself an outlet of the coarse map (its edge
or a nodata border) and receives water. Each crossing is placed at the fine cell under the
midpoint of the two centres (the footprint cell's centre for a coarse outlet), moved to the
nearest fine boundary cell (an edge cell or a border of the fine DEM's nodata), and widened
to the fine boundary cells within half a coarse cell of it (Chebyshev distance in cells of the
fine grid: the 3 fine cells of a 90 m face on a 30 m grid, none with equal cell sizes). Only
those cells and the borders of the fine DEM's nodata drain out: the cells where inflow crosses
are not outlets, so the entering water cannot run straight back out beside the channel.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
from scipy import ndimage

from unerode_cli.errors import InputError
from unerode_cli.hydro import outlet_mask, route
from unerode_cli.hydro.routing import Routing
from unerode_cli.io.coarse_runs import CoarseRun, CoarseState
from unerode_cli.io.grid_rasters import same_crs
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes.inflow import InflowHistory, interpolate_rows

#: Row and column offsets of the 8 neighbours, in the order of ``Routing.fractions``.
OFFSETS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))
#: An outflow crossing is where the water leaves when at least this share of what crosses there
#: never comes back into the footprint downstream (dimensionless).
LEAVING_SHARE = 0.5


@dataclass(frozen=True)
class NodeLevels:
    """Elevations (m) of N boundary nodes at K ages (ka, increasing): float64[K, N]."""

    ages_ka: np.ndarray
    levels: np.ndarray

    def at(self, age_ka: float) -> np.ndarray:
        """float64[N] levels at ``age_ka``, linear between the ages."""
        if self.ages_ka.size == 1:
            return self.levels[0]
        return interpolate_rows(self.ages_ka, self.levels, age_ka)


@dataclass(frozen=True)
class Nesting:
    """What a fine run takes from its coarse run: the inflow and the boundary-node levels."""

    inflow: InflowHistory
    levels: NodeLevels
    rivers: int

    def summary(self) -> str:
        q = self.inflow.discharge.sum(axis=1)
        return (f"inflow from the coarse run through {self.rivers} cell(s): "
                f"{q.min():.3g}–{q.max():.3g} m³/y of water over {self.inflow.ages_ka.size} age(s)")


def nest(coarse: CoarseRun, fine: Terrain, outlets: np.ndarray, nodes: np.ndarray,
         span_ka: tuple[float, float],
         on_age: Callable[[float], None] | None = None) -> Nesting:
    """Read the coarse run at each of its ages that the fine run's span needs.

    Args:
        coarse: the coarse run's nesting rasters.
        fine: the fine DEM.
        outlets: bool[ny, nx] the fine run's outlets at its start; no river enters there.
        nodes: bool[ny, nx] the fine boundary nodes whose levels follow the coarse surface.
        span_ka: (start, end) ages of the fine run (ka); the coarse run must cover them.
        on_age: told each age as it is read (progress).

    Raises:
        InputError: the coarse ages do not cover the span, or a coarse grid in another CRS or
            not covering the fine map.
    """
    used = _used_ages(coarse, span_ka)
    free = _nearest_free(fine, outlets)
    node_rows, node_cols = np.nonzero(nodes)
    entries: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    levels = []
    footprint = None
    for age in used:
        if on_age is not None:
            on_age(float(age))
        state = coarse.state(float(age))
        if footprint is None:  # the coarse grid is the same at every age
            _check_cover(state.terrain, fine, coarse)
            footprint = _footprint(state.terrain, fine)
        entries.append(_crossings(state, fine, footprint, free))
        levels.append(_sample(state.terrain, fine, node_rows, node_cols))
    cells = np.unique(np.concatenate([entry[0] for entry in entries]))
    q = np.zeros((used.size, cells.size))
    qs = np.zeros((used.size, cells.size))
    for k, (entry_cells, water, sediment) in enumerate(entries):
        where = np.searchsorted(cells, entry_cells)
        q[k, where], qs[k, where] = water, sediment
    inflow = InflowHistory(fine.shape, cells, used.astype(np.float64), q, qs)
    return Nesting(inflow, NodeLevels(used.astype(np.float64), np.array(levels)), int(cells.size))


def crossing_outlets(coarse: CoarseRun, fine: Terrain, span_ka: tuple[float, float]) -> np.ndarray:
    """bool[ny, nx] the fine boundary cells where the coarse run's water leaves the fine map's
    footprint at any coarse age that the fine run's span (``span_ka``, ka) needs (module
    docstring: "Where the water leaves").

    Raises:
        InputError: the coarse ages do not cover the span, a coarse grid in another CRS or not
            covering the fine map, a coarse surface that cannot be routed, or no crossing at all.
    """
    markers = np.zeros(fine.shape, dtype=bool)
    footprint = None
    scale = 1.0
    for age in _used_ages(coarse, span_ka):
        state = coarse.state(float(age))
        if footprint is None:
            _check_cover(state.terrain, fine, coarse)
            footprint = _footprint(state.terrain, fine)
            scale = abs(state.terrain.transform.a) / abs(fine.transform.a)
        rows, cols = _leaving(state, fine, footprint)
        markers[rows, cols] = True
    boundary = outlet_mask(fine.grid, "all")
    if not markers.any() or not boundary.any():
        raise InputError(f"the water of the coarse run {coarse.folder} leaves the fine map nowhere; "
                         "give its outlets with --outlets.")
    nearest = ndimage.distance_transform_edt(~boundary, sampling=(fine.dy, fine.dx),
                                             return_distances=False, return_indices=True)
    snapped = np.zeros(fine.shape, dtype=bool)
    snapped[nearest[0][markers], nearest[1][markers]] = True
    reach = max(int(0.5 * scale + 1e-9), 0)
    if reach:
        snapped = ndimage.binary_dilation(snapped, structure=np.ones((2 * reach + 1,) * 2, dtype=bool))
    return snapped & boundary


def _used_ages(coarse: CoarseRun, span_ka: tuple[float, float]) -> np.ndarray:
    """float64[K] the coarse ages (ka, increasing) that bracket the fine run's ``span_ka``;
    InputError when the coarse run does not cover it."""
    ages = np.asarray(coarse.ages_ka, dtype=np.float64)
    lo, hi = min(span_ka), max(span_ka)
    if ages[0] > lo + 1e-9 or ages[-1] < hi - 1e-9:
        raise InputError(f"the coarse run {coarse.folder} kept ages {ages[0]:g}–{ages[-1]:g} ka, not "
                         f"the whole fine run from {span_ka[0]:g} to {span_ka[1]:g} ka; run it over "
                         "that span with --write-fluxes.")
    first = max(int(np.searchsorted(ages, lo + 1e-9)) - 1, 0)
    last = min(int(np.searchsorted(ages, hi - 1e-9)), ages.size - 1)
    return ages[first:last + 1]


def _check_cover(coarse: Terrain, fine: Terrain, run: CoarseRun) -> None:
    if not same_crs(coarse.crs_wkt, fine.crs_wkt):
        raise InputError(f"the coarse run {run.folder} is not in the fine DEM's CRS.")
    ny, nx = fine.shape
    corners = np.array([fine.transform @ (c, r) for r, c in ((0, 0), (0, nx), (ny, 0), (ny, nx))])
    cols, rows = np.array([~coarse.transform @ tuple(p) for p in corners]).T
    cny, cnx = coarse.shape
    tolerance = 1e-6
    if cols.min() < -tolerance or rows.min() < -tolerance or cols.max() > cnx + tolerance \
            or rows.max() > cny + tolerance:
        raise InputError(f"the fine DEM reaches outside the coarse run {run.folder}; the coarse map "
                         "must cover the fine one.")


def _nearest_free(fine: Terrain, outlets: np.ndarray) -> np.ndarray:
    """int64[ny, nx] flat index of the fine cell where inflow arriving on each cell enters: the
    cell itself when it is valid and not an outlet ("free"); else its lowest free neighbour (of
    8); else, without one, the nearest free cell (in metres)."""
    blocked = fine.nodata_mask | outlets
    if blocked.all():
        raise InputError("the fine DEM has no cell that is neither nodata nor an outlet for the "
                         "inflow to enter.")
    rows, cols = ndimage.distance_transform_edt(blocked, sampling=(fine.dy, fine.dx),
                                                return_distances=False, return_indices=True)
    ny, nx = fine.shape
    entry = rows * nx + cols
    z = np.where(blocked, np.inf, fine.elevation.astype(np.float64))
    padded = np.pad(z, 1, constant_values=np.inf)
    index = np.pad(np.arange(ny * nx, dtype=np.int64).reshape(ny, nx), 1, constant_values=-1)
    lowest = np.full((ny, nx), np.inf)
    for di, dj in OFFSETS:
        around = padded[1 + di:1 + di + ny, 1 + dj:1 + dj + nx]
        lower = around < lowest
        lowest[lower] = around[lower]
        entry[blocked & lower] = index[1 + di:1 + di + ny, 1 + dj:1 + dj + nx][blocked & lower]
    free = ~blocked
    entry[free] = np.flatnonzero(free)
    return entry


def _footprint(coarse: Terrain, fine: Terrain) -> np.ndarray:
    """bool[cny, cnx] coarse cells whose centres fall on valid fine cells."""
    cny, cnx = coarse.shape
    rows, cols = np.mgrid[0:cny, 0:cnx] + 0.5
    x, y = coarse.transform @ (cols, rows)
    fc, fr = ~fine.transform @ (x, y)
    ny, nx = fine.shape
    inside = (fr >= 0) & (fr < ny) & (fc >= 0) & (fc < nx)
    r = np.clip(np.floor(fr).astype(np.int64), 0, ny - 1)
    c = np.clip(np.floor(fc).astype(np.int64), 0, nx - 1)
    return inside & ~fine.nodata_mask[r, c] & ~coarse.nodata_mask


def _crossings(state: CoarseState, fine: Terrain, footprint: np.ndarray,
               free: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fine cells (flat indices, int64[M], sorted) where water and sediment cross into the
    fine map's ``footprint`` (bool[cny, cnx], :func:`_footprint`) at one age, with their Q and
    Q_s (m³/y, float64[M])."""
    coarse = state.terrain
    grid = coarse.grid
    fractions = _routing(state).fractions()
    ring = ndimage.binary_dilation(footprint, structure=np.ones((3, 3), dtype=bool)) \
        & ~footprint & grid.valid
    rr, rc = np.nonzero(ring)
    cny, cnx = coarse.shape
    ny, nx = fine.shape
    cells, water, sediment = [np.zeros(0, dtype=np.int64)], [np.zeros(0)], [np.zeros(0)]
    for k, (di, dj) in enumerate(OFFSETS):
        tr, tc = rr + di, rc + dj
        inside = (tr >= 0) & (tr < cny) & (tc >= 0) & (tc < cnx)
        share = np.zeros(rr.size)
        share[inside] = fractions[rr[inside], rc[inside], k] * footprint[tr[inside], tc[inside]]
        take = share > 0
        if not take.any():
            continue
        x, y = coarse.transform @ (rc[take] + 0.5 + 0.5 * dj, rr[take] + 0.5 + 0.5 * di)
        fc, fr = ~fine.transform @ (x, y)
        r = np.clip(np.floor(fr).astype(np.int64), 0, ny - 1)
        c = np.clip(np.floor(fc).astype(np.int64), 0, nx - 1)
        cells.append(free[r, c])
        water.append(share[take] * state.discharge[rr[take], rc[take]])
        sediment.append(share[take] * state.sediment_flux[rr[take], rc[take]])
    unique, inverse = np.unique(np.concatenate(cells), return_inverse=True)
    return (unique, np.bincount(inverse, np.concatenate(water), unique.size),
            np.bincount(inverse, np.concatenate(sediment), unique.size))


def _routing(state: CoarseState) -> Routing:
    """The coarse surface at one age routed with multiple flow directions, every edge and
    nodata border an outlet."""
    grid = state.terrain.grid
    try:
        return route(state.terrain.elevation, grid, outlet_mask(grid, "all"), "mfd")
    except ValueError as exc:
        raise InputError(f"the coarse run at {state.age_ka:g} ka cannot be routed: {exc}.") from None


def _leaving(state: CoarseState, fine: Terrain, footprint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The fine cells (rows, columns: int64[M] each, inside the fine grid) under the points where
    water leaves the ``footprint`` (bool[cny, cnx]) at one age: the midpoints between each
    footprint cell that sends a share of a positive Q to a cell outside the footprint, of whose
    water at least :data:`LEAVING_SHARE` never comes back into it, and that cell; and the
    centres of the footprint's coarse outlets that receive water."""
    coarse = state.terrain
    routing = _routing(state)
    fractions = routing.fractions()
    offsets = np.array(OFFSETS, dtype=np.int64)
    back = _returning(routing.order.astype(np.int64), fractions, footprint, offsets)
    wet = footprint & (state.discharge > 0)
    fr, fc = np.nonzero(wet)
    cny, cnx = coarse.shape
    points_c, points_r = [fc + 0.5], [fr + 0.5]
    keep = [routing.outlets[fr, fc]]
    for k, (di, dj) in enumerate(OFFSETS):
        tr, tc = fr + di, fc + dj
        inside = (tr >= 0) & (tr < cny) & (tc >= 0) & (tc < cnx)
        gone = ~inside
        gone[inside] = ~footprint[tr[inside], tc[inside]] \
            & (back[tr[inside], tc[inside]] <= 1.0 - LEAVING_SHARE)
        keep.append(gone & (fractions[fr, fc, k] > 0))
        points_c.append(fc + 0.5 + 0.5 * dj)
        points_r.append(fr + 0.5 + 0.5 * di)
    take = np.concatenate(keep)
    x, y = coarse.transform @ (np.concatenate(points_c)[take], np.concatenate(points_r)[take])
    col, row = ~fine.transform @ (x, y)
    ny, nx = fine.shape
    return (np.clip(np.floor(row).astype(np.int64), 0, ny - 1),
            np.clip(np.floor(col).astype(np.int64), 0, nx - 1))


@numba.njit(cache=True)
def _returning(order: np.ndarray, fractions: np.ndarray, footprint: np.ndarray,
               offsets: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """float64[ny, nx] the share of each coarse cell's water that reaches the ``footprint``
    (bool[ny, nx]) downstream: 1 on the footprint, 0 on outlets that are not in it, else the sum
    over its receivers of its ``fractions`` (float64[ny, nx, 8], in the order of ``offsets``,
    int64[8, 2]) times theirs. ``order`` (int64[N]): the valid cells' flat indices by
    descending routing surface, walked backwards so that receivers come first."""
    ny, nx = footprint.shape
    back = np.zeros((ny, nx))
    for n in range(order.size - 1, -1, -1):
        r, c = divmod(order[n], nx)
        if footprint[r, c]:
            back[r, c] = 1.0
            continue
        total = 0.0
        for k in range(8):
            share = fractions[r, c, k]
            if share > 0.0:
                total += share * back[r + offsets[k, 0], c + offsets[k, 1]]
        back[r, c] = total
    return back


def _sample(coarse: Terrain, fine: Terrain, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """float64[N] coarse elevation (m, bilinear; nodata filled from the nearest valid cell) at
    the centres of the fine cells (rows, cols)."""
    z = coarse.elevation
    if coarse.nodata_mask.any():
        index = ndimage.distance_transform_edt(coarse.nodata_mask, return_distances=False,
                                               return_indices=True)
        z = z[tuple(index)]
    x, y = fine.transform @ (cols + 0.5, rows + 0.5)
    cc, cr = ~coarse.transform @ (x, y)
    return ndimage.map_coordinates(z, [cr - 0.5, cc - 0.5], order=1, mode="nearest")
