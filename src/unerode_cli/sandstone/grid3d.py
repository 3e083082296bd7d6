"""The regular 3D grid of the sandstone simulator (002 §3): the MLS-MPM background grid, the
occupancy grid of surfaces and normals, and the grid of wind shelter and deposition share it.

Axes: x east, y north, z up (metres). Cell (i, j, k) spans
``origin + h·([i, i+1) × [j, j+1) × [k, k+1))``; arrays over cells have shape ``(nx, ny, nz)``
and are indexed ``[i, j, k]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class Grid3D:
    """A regular grid of cubic cells of edge ``h`` (m) from ``origin`` (m, the low corner)."""

    origin: tuple[float, float, float]
    h: float
    shape: tuple[int, int, int]

    def __post_init__(self) -> None:
        if not self.h > 0.0:
            raise ValueError(f"the cell size must be positive, not {self.h}")
        if min(self.shape) < 1:
            raise ValueError(f"a grid needs at least one cell along each axis, not {self.shape}")

    @property
    def size(self) -> np.ndarray:
        """Extent along x, y, z (m)."""
        return np.asarray(self.shape, dtype=np.float64) * self.h

    @property
    def cell_count(self) -> int:
        return int(np.prod(self.shape))

    def cells_of(self, positions: np.ndarray) -> np.ndarray:
        """Integer cell indices ``(N, 3)`` of points ``(N, 3)`` (m); not clipped to the grid."""
        return np.floor((positions - np.asarray(self.origin)) / self.h).astype(np.int64)

    def inside(self, cells: np.ndarray) -> np.ndarray:
        """Which of the cell indices ``(N, 3)`` lie in the grid."""
        return np.all((cells >= 0) & (cells < np.asarray(self.shape)), axis=1)

    def centres(self, cells: np.ndarray) -> np.ndarray:
        """Centres (m) of the cells ``(N, 3)``."""
        return np.asarray(self.origin) + (cells + 0.5) * self.h

    def occupancy(self, positions: np.ndarray) -> np.ndarray:
        """Particles per cell, ``int32 (nx, ny, nz)``; particles outside the grid are not counted."""
        counts = np.zeros(self.shape, dtype=np.int32)
        _count_particles(np.ascontiguousarray(positions, dtype=np.float64),
                         np.asarray(self.origin, dtype=np.float64), self.h, counts)
        return counts


@numba.njit(cache=True)
def _count_particles(positions: np.ndarray, origin: np.ndarray, h: float, counts: np.ndarray) -> None:
    nx, ny, nz = counts.shape
    for p in range(positions.shape[0]):
        i = int(np.floor((positions[p, 0] - origin[0]) / h))
        j = int(np.floor((positions[p, 1] - origin[1]) / h))
        k = int(np.floor((positions[p, 2] - origin[2]) / h))
        if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
            counts[i, j, k] += 1
