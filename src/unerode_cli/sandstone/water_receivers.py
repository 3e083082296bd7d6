"""Receivers of water on the 3D grid (002 §6.2, Fig. 4).

The grid is the MPM grid (``Lattice.mpm_grid``, about 8 particles a cell). A cell is *empty*
when it holds no particle and *filled* otherwise; a filled cell is a *surface cell* when the
cell above it is empty (or it is in the grid's top layer), and its proxy elevation z_c is the
altitude (m) of its highest particle, which orders the surface cells (002: "preventing any
cycle in the flow paths"). Every cell gets one receiver, where its water goes next:

- an empty cell: the first filled cell below it in its column (water falls), or out of the
  domain when there is none (it falls on the ground, the base level);
- a filled cell over an empty cell (a ceiling): the empty cell below (Fig. 4a);
- else a filled cell with empty side neighbours (of the 4 at its level; beyond the grid's
  sides is empty, and out of the domain): one of them, drawn uniformly (Fig. 4b);
- else a surface cell with lower surface neighbours (4 neighbours, z_n < z_c): one of them,
  drawn with a probability proportional to z_c − z_n (Fig. 4c);
- else a surface cell is a local minimum (``PIT``, rerouted by ``basins``) and any other
  cell is solid rock (``SOLID``, masked out).

The cell below the grid is the ground, which is rock: a filled cell of the bottom layer is not
a ceiling. Walls and ceilings get receivers although water cannot reach them (002: "this choice
allows the evacuation of sediments"); here they carry the water of sources put in them.

Every move goes down a level, or from a filled cell into an empty cell of its level (which then
goes down), or between surface cells of strictly decreasing z_c, so receivers never form a
cycle. Random draws come from the counter-based hash of (seed, frame, cell) of ``hashing``:
the receivers do not depend on the number of threads.

Cells are numbered in C order of ``(nx, ny, nz)``: cell (i, j, k) is ``(i·ny + j)·nz + k``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.hashing import DRAW_WATER_SIDE, DRAW_WATER_SURFACE, uniform

#: Receiver codes of the cells without a receiver cell: water leaves the domain; a local
#: minimum; solid rock (no receiver, masked out); a cell of a basin sealed inside the rock
#: (set by ``basins``).
EXIT, PIT, SOLID, SEALED = -1, -2, -3, -4
#: The 4 side neighbours (di, dj).
_SIDES = np.array([(1, 0), (-1, 0), (0, 1), (0, -1)], dtype=np.int64)


@dataclass(frozen=True)
class WaterReceivers:
    """The receivers of one frame (module docstring).

    Attributes:
        grid: the grid they are on.
        top: proxy elevation (m) of each cell, the altitude of its highest particle; −∞ for
            empty cells; ``float64 (nx, ny, nz)``.
        receiver: ``int64 (nx·ny·nz,)``, the receiving cell's index or ``EXIT``, ``PIT``,
            ``SOLID``.
    """

    grid: Grid3D
    top: np.ndarray
    receiver: np.ndarray

    @property
    def filled(self) -> np.ndarray:
        """Which cells hold particles, ``bool (nx, ny, nz)``."""
        return self.top > -np.inf


def cell_tops(positions: np.ndarray, grid: Grid3D) -> np.ndarray:
    """Altitude (m) of the highest of the ``positions`` ``(N, 3)`` (m) in each cell of ``grid``,
    −∞ where there is none, ``float64 (nx, ny, nz)``; points outside the grid are left out."""
    top = np.full(grid.shape, -np.inf)
    _cell_tops(np.ascontiguousarray(positions, dtype=np.float64), np.asarray(grid.origin, dtype=np.float64),
               grid.h, top)
    return top


def water_receivers(positions: np.ndarray, grid: Grid3D, seed: int, frame: int) -> WaterReceivers:
    """The receivers of every cell of ``grid`` (module docstring) for the particles at
    ``positions`` ``(N, 3)`` (m); ``seed`` and ``frame`` (integers ≥ 0) key the random choices."""
    top = cell_tops(positions, grid)
    receiver = np.empty(grid.cell_count, dtype=np.int64)
    _receivers(top, np.uint64(seed), np.uint64(frame), _SIDES, receiver)
    return WaterReceivers(grid, top, receiver)


@numba.njit(cache=True)
def _cell_tops(positions, origin, h, top):
    nx, ny, nz = top.shape
    for p in range(positions.shape[0]):
        i = int(math.floor((positions[p, 0] - origin[0]) / h))
        j = int(math.floor((positions[p, 1] - origin[1]) / h))
        k = int(math.floor((positions[p, 2] - origin[2]) / h))
        if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz and positions[p, 2] > top[i, j, k]:
            top[i, j, k] = positions[p, 2]


@numba.njit(cache=True, inline="always")
def is_surface(top, i, j, k):
    """Whether cell (i, j, k) of the grid is a surface cell: filled, under an empty cell or
    the grid's top."""
    return top[i, j, k] > -np.inf and (k == top.shape[2] - 1 or top[i, j, k + 1] == -np.inf)


@numba.njit(cache=True, parallel=True)
def _receivers(top, seed, frame, sides, receiver):
    nx, ny, nz = top.shape
    for column in numba.prange(nx * ny):
        i, j = column // ny, column % ny
        weights = np.zeros(4)
        below = -1  # level of the highest filled cell below the current one
        for k in range(nz):
            c = column * nz + k
            z = top[i, j, k]
            if z == -np.inf:
                receiver[c] = EXIT if below < 0 else column * nz + below
                continue
            below = k
            if k > 0 and top[i, j, k - 1] == -np.inf:
                receiver[c] = c - 1
                continue
            empty = 0
            for d in range(4):
                a, b = i + sides[d, 0], j + sides[d, 1]
                if a < 0 or b < 0 or a >= nx or b >= ny or top[a, b, k] == -np.inf:
                    empty += 1
            if empty > 0:
                pick = int(uniform(seed, frame, c, DRAW_WATER_SIDE) * empty)
                for d in range(4):
                    a, b = i + sides[d, 0], j + sides[d, 1]
                    outside = a < 0 or b < 0 or a >= nx or b >= ny
                    if outside or top[a, b, k] == -np.inf:
                        if pick == 0:
                            receiver[c] = EXIT if outside else (a * ny + b) * nz + k
                            break
                        pick -= 1
                continue
            if not is_surface(top, i, j, k):
                receiver[c] = SOLID
                continue
            total = 0.0
            for d in range(4):  # every side neighbour is in the grid and filled here
                a, b = i + sides[d, 0], j + sides[d, 1]
                weights[d] = 0.0
                if is_surface(top, a, b, k) and top[a, b, k] < z:
                    weights[d] = z - top[a, b, k]
                    total += weights[d]
            receiver[c] = PIT
            if total > 0.0:
                pick = uniform(seed, frame, c, DRAW_WATER_SURFACE) * total
                for d in range(4):
                    if weights[d] > 0.0:
                        receiver[c] = (i + sides[d, 0]) * ny * nz + (j + sides[d, 1]) * nz + k
                        pick -= weights[d]
                        if pick < 0.0:
                            break
