"""Water discharge on the 3D grid (002 §6.2, "Flow Routing"): the upstream integral of
precipitation and water sources along the receivers of ``basins.route_depressions``.

Inputs, in m³/y: precipitation p (m/y) falls on the top of the domain, and each column's
water lands on its topmost filled cell (002: "each cell at the upper boundary of the domain"),
which receives p·h² (h the cell size, m); a column without rock lets it fall to the ground,
out of the domain, and it is not counted. A point source (x, y, z, Q) adds Q to the cell
that contains its point (inside a wall or a cavity: that cell's water).

Q of a cell is its input plus the Q of every cell whose receiver it is, accumulated in the
routing's topological order (with the empty cells that hold a source and that nothing drains
into put first) (002 uses Fastflow's rake-compress on the GPU; a serial pass over
a topological order gives the same sums). Water is conserved: the inflow leaves through the
exits, or is lost in what depression routing removed (sealed basins) and in solid rock
(a source buried in it); those cells carry no water.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np

from unerode_cli.sandstone.basins import Routing
from unerode_cli.sandstone.water_receivers import SOLID


@dataclass(frozen=True)
class Discharge:
    """The discharge of one frame.

    Attributes:
        q: Q of each cell (m³/y), ``float64 (nx, ny, nz)``; 0 in solid rock and sealed basins.
        inflow: precipitation on the rock plus the sources (m³/y).
        outflow: what leaves the domain through the exits (m³/y).
        lost: what falls into sealed basins or solid rock (m³/y); inflow = outflow + lost.
    """

    q: np.ndarray
    inflow: float
    outflow: float
    lost: float


def discharge(routing: Routing, precipitation: float,
              sources: Sequence[tuple[float, float, float, float]] = ()) -> Discharge:
    """Q on every cell of ``routing`` (module docstring).

    Args:
        routing: receivers after depression routing.
        precipitation: p (m/y), ≥ 0.
        sources: points (x, y, z) (m) and their discharges Q (m³/y, ≥ 0); ValueError for a
            point outside the grid.
    """
    if not (math.isfinite(precipitation) and precipitation >= 0.0):
        raise ValueError(f"the precipitation must be a finite number ≥ 0 m/y, not {precipitation}")
    grid = routing.grid
    q = np.zeros(grid.cell_count)
    _rain(routing.top, precipitation * grid.h * grid.h, q)
    order = routing.order
    if len(sources):
        points = np.asarray(sources, dtype=np.float64).reshape(-1, 4)
        if np.any(~np.isfinite(points[:, 3]) | (points[:, 3] < 0.0)):
            raise ValueError("a water source's discharge must be a finite number ≥ 0 m³/y")
        cells = grid.cells_of(points[:, :3])
        outside = ~grid.inside(cells)
        if outside.any():
            x, y, z = points[np.argmax(outside), :3]
            raise ValueError(f"the water source at ({x:g}, {y:g}, {z:g}) m lies outside the grid")
        index = np.ravel_multi_index(cells.T, grid.shape)
        np.add.at(q, index, points[:, 3])
        # a source in an empty cell that nothing drains into: first in the order (no donors)
        dry = np.unique(index[(routing.receiver[index] > SOLID) & ~np.isin(index, order)])
        order = np.concatenate([dry, order])
    inflow, lost = _remove_lost(routing.receiver, q)
    outflow = _accumulate(order, routing.receiver, q)
    return Discharge(q.reshape(grid.shape), inflow, outflow, lost)


@numba.njit(cache=True, parallel=True)
def _rain(top, rain, q):
    """Add ``rain`` (m³/y) to the topmost filled cell of every column."""
    nx, ny, nz = top.shape
    for column in numba.prange(nx * ny):
        i, j = column // ny, column % ny
        for k in range(nz - 1, -1, -1):
            if top[i, j, k] > -np.inf:
                q[column * nz + k] += rain
                break


@numba.njit(cache=True)
def _remove_lost(receiver, q):
    """Empty the inputs of solid cells and sealed basins, in place; returns (the total input,
    what was removed) (m³/y)."""
    total, lost = 0.0, 0.0
    for c in range(q.size):
        total += q[c]
        if receiver[c] <= SOLID:
            lost += q[c]
            q[c] = 0.0
    return total, lost


@numba.njit(cache=True)
def _accumulate(order, receiver, q):
    """Q ← input + Σ donors' Q in topological order, in place; returns the outflow (m³/y)."""
    outflow = 0.0
    for t in range(order.size):
        c = order[t]
        r = receiver[c]
        if r >= 0:
            q[r] += q[c]
        else:
            outflow += q[c]
    return outflow
