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

import numpy as np

from unerode_cli.sandstone.grid3d import Grid3D

_CONNECTIVITY = np.ones((3, 3, 3), dtype=bool)


def unsupported(positions: np.ndarray, grid: Grid3D) -> np.ndarray:
    """bool ``(N,)``: the particles at ``positions`` ``(N, 3)`` (m) that belong to a piece not
    connected to the ground of ``grid`` (module docstring). Particles outside the grid count as
    unsupported."""
    from scipy import ndimage

    cells = grid.cells_of(np.asarray(positions, dtype=np.float64).reshape(-1, 3))
    inside = grid.inside(cells)
    occupied = np.zeros(grid.shape, dtype=bool)
    occupied[tuple(cells[inside].T)] = True
    labels, count = ndimage.label(occupied, structure=_CONNECTIVITY)
    if count == 0:
        return ~inside
    grounded = np.zeros(count + 1, dtype=bool)
    grounded[np.unique(labels[:, :, 0])] = True
    grounded[0] = False
    falls = ~inside
    falls[inside] = ~grounded[labels[tuple(cells[inside].T)]]
    return falls
