"""Rock that has lost its support (002 Fig. 3): pieces no longer connected to the ground.

Erosion can cut a piece of rock off everything that holds it (the bridge of an arch worn
through, a cap whose neck is gone). Such a piece falls. Its fall takes seconds, while a frame is
centuries and the stress solver (``mpm``) relaxes to the static state with damped substeps of
~1e-4 s, so the fall is not integrated: a piece found unsupported at the end of a frame is
removed, and its particles are passed to deposition (002 §7), which lays them as debris at the
angle of repose in the columns below — it lands as the talus 002 Fig. 3 sketches. Fracture is
not modelled: a piece hanging on by a thread of particles stays until erosion cuts the thread.

Connectivity: two particles are connected when their cells of the surface grid (one particle a
cell) touch, faces, edges or corners (26-connectivity); a piece is supported when one of its
cells lies on the ground, the grid's lowest layer of cells, to which the stress solver bonds
the rock.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.surface import filled_cells

#: Cell states of ``unsupported``'s search: empty, holding particles (not yet known to be
#: grounded; ``filled_cells``' 1), holding particles and connected to the ground.
_EMPTY, _OCCUPIED, _GROUNDED = 0, 1, 2


def unsupported(positions: np.ndarray, grid: Grid3D) -> np.ndarray:
    """bool ``(N,)``: the particles at ``positions`` ``(N, 3)`` (m) that belong to a piece not
    connected to the ground of ``grid`` (module docstring). Particles outside the grid count as
    unsupported.

    The grounded cells are found without labelling every piece: a column's run of occupied
    cells from the lowest layer up is grounded; the other occupied cells are grounded when a
    26-connected path of occupied cells joins them to one of those (a search from the grounded
    cells that border them). A piece is grounded exactly when it holds a cell of the lowest
    layer, so this is the connected-component test of the module docstring.
    """
    positions = np.ascontiguousarray(np.asarray(positions, dtype=np.float64).reshape(-1, 3))
    origin = np.asarray(grid.origin, dtype=np.float64)
    state = filled_cells(positions, grid)
    _ground_columns(state)
    _ground_the_rest(state, _borders(state))
    falls = np.empty(positions.shape[0], dtype=np.bool_)
    _lookup_falls(positions, origin, grid.h, state, falls)
    return falls


@numba.njit(cache=True, inline="always")
def _cell(positions, p, origin, h):
    return (int(math.floor((positions[p, 0] - origin[0]) / h)),
            int(math.floor((positions[p, 1] - origin[1]) / h)),
            int(math.floor((positions[p, 2] - origin[2]) / h)))


@numba.njit(cache=True, parallel=True)
def _ground_columns(state):
    """Each column's run of occupied cells from the lowest layer up: grounded."""
    nx, ny, nz = state.shape
    for c in numba.prange(nx * ny):
        i, j = c // ny, c % ny
        k = 0
        while k < nz and state[i, j, k] == _OCCUPIED:
            state[i, j, k] = _GROUNDED
            k += 1


@numba.njit(cache=True, inline="always")
def _touches_grounded(state, i, j, k):
    """Whether a 26-neighbour of cell (i, j, k) is grounded."""
    nx, ny, nz = state.shape
    for a in range(max(i - 1, 0), min(i + 2, nx)):
        for b in range(max(j - 1, 0), min(j + 2, ny)):
            for d in range(max(k - 1, 0), min(k + 2, nz)):
                if state[a, b, d] == _GROUNDED:
                    return True
    return False


@numba.njit(cache=True, parallel=True)
def _border_flags(state, flags):
    """Which occupied, not yet grounded cells have a grounded 26-neighbour (reads ``state``,
    writes ``flags`` only)."""
    nx, ny, nz = state.shape
    for c in numba.prange(nx * ny):
        i, j = c // ny, c % ny
        for k in range(nz):
            if state[i, j, k] == _OCCUPIED and _touches_grounded(state, i, j, k):
                flags[i, j, k] = True


def _borders(state: np.ndarray) -> np.ndarray:
    """Flat indices of the occupied cells next to a grounded one, the search's seeds."""
    flags = np.zeros(state.shape, dtype=np.bool_)
    _border_flags(state, flags)
    return np.flatnonzero(flags)


@numba.njit(cache=True)
def _ground_the_rest(state, seeds):
    """Ground every occupied cell 26-connected to a ``seeds`` cell (a depth-first search)."""
    nx, ny, nz = state.shape
    flat = state.reshape(-1)
    stack = np.empty(flat.size, dtype=np.int64)
    top = 0
    for s in seeds:
        if flat[s] == _OCCUPIED:
            flat[s] = _GROUNDED
            stack[top] = s
            top += 1
    while top > 0:
        top -= 1
        c = stack[top]
        i, j, k = c // (ny * nz), (c // nz) % ny, c % nz
        for a in range(max(i - 1, 0), min(i + 2, nx)):
            for b in range(max(j - 1, 0), min(j + 2, ny)):
                for d in range(max(k - 1, 0), min(k + 2, nz)):
                    n = (a * ny + b) * nz + d
                    if flat[n] == _OCCUPIED:
                        flat[n] = _GROUNDED
                        stack[top] = n
                        top += 1


@numba.njit(cache=True, parallel=True)
def _lookup_falls(positions, origin, h, state, falls):
    nx, ny, nz = state.shape
    for p in numba.prange(positions.shape[0]):
        i, j, k = _cell(positions, p, origin, h)
        falls[p] = not (0 <= i < nx and 0 <= j < ny and 0 <= k < nz and state[i, j, k] == _GROUNDED)
