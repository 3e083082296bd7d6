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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from unerode_cli.errors import InputError
from unerode_cli.hydro import outlet_mask, route
from unerode_cli.io.coarse_runs import CoarseRun, CoarseState
from unerode_cli.io.grid_rasters import same_crs
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes.inflow import InflowHistory, interpolate_rows

#: Row and column offsets of the 8 neighbours, in the order of ``Routing.fractions``.
OFFSETS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


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
    ages = np.asarray(coarse.ages_ka)
    lo, hi = min(span_ka), max(span_ka)
    if ages[0] > lo + 1e-9 or ages[-1] < hi - 1e-9:
        raise InputError(f"the coarse run {coarse.folder} kept ages {ages[0]:g}–{ages[-1]:g} ka, not "
                         f"the whole fine run from {span_ka[0]:g} to {span_ka[1]:g} ka; run it over "
                         "that span with --write-fluxes.")
    first = max(int(np.searchsorted(ages, lo + 1e-9)) - 1, 0)
    last = min(int(np.searchsorted(ages, hi - 1e-9)), ages.size - 1)
    used = ages[first:last + 1]
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
    try:
        routing = route(coarse.elevation, grid, outlet_mask(grid, "all"), "mfd")
    except ValueError as exc:
        raise InputError(f"the coarse run at {state.age_ka:g} ka cannot be routed: {exc}.") from None
    fractions = routing.fractions()
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
