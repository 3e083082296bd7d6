"""numba walks along a D8 flow network (used by ``river``)."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def trace_downstream(receivers, start):
    """Flat indices from ``start`` down the D8 ``receivers`` (int64[n], -1 = no receiver) to
    the cell that has no receiver (an outlet), both included."""
    path = np.empty(receivers.size, dtype=np.int64)
    count = 0
    cell = start
    while cell >= 0 and count < receivers.size:
        path[count] = cell
        count += 1
        cell = receivers[cell]
    return path[:count]


@numba.njit(cache=True)
def trace_upstream(receivers, area, nx, start, min_area):
    """Flat indices from ``start`` up the D8 network, always into the donor of largest
    drainage ``area`` (m², float64[n]), while that donor drains at least ``min_area`` (m²).

    A donor of cell i is one of its 8 neighbours whose receiver is i. The path starts at
    ``start`` and ends at its head (the last cell with a donor above ``min_area``)."""
    n = receivers.size
    ny = n // nx
    path = np.empty(n, dtype=np.int64)
    count = 0
    cell = start
    while cell >= 0 and count < n:
        path[count] = cell
        count += 1
        r, c = cell // nx, cell % nx
        best, best_area = -1, min_area
        for dr in range(-1, 2):
            for dc in range(-1, 2):
                rr, cc = r + dr, c + dc
                if (dr or dc) and 0 <= rr < ny and 0 <= cc < nx:
                    k = rr * nx + cc
                    if receivers[k] == cell and area[k] >= best_area:
                        best, best_area = k, area[k]
        cell = best
    return path[:count]
