"""Numba kernels of the lattice (``lattice``): node elevations and degrees of freedom.

Each is one pass over the nodes, without the temporaries of a vectorised NumPy form, and gives
the same numbers bit for bit (``tests/glacier/test_lattice_kernels.py`` holds the NumPy forms);
both are rebuilt on every level of the multigrid at every velocity solve.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def layer_elevations(bed, thickness, n_layers, dz_min):
    """ζ float64[N + 1, ny, nx] (m): b + k·(H/N) where H ≥ N·dz_min, else b + min(k·dz_min, H);
    ζ[N] = b + H exactly, whatever the rounding of N·(H/N) (``lattice.layer_elevations``)."""
    ny, nx = bed.shape
    full = n_layers * dz_min
    zeta = np.empty((n_layers + 1, ny, nx))
    for k in range(n_layers + 1):
        for j in range(ny):
            for i in range(nx):
                b = bed[j, i]
                h = thickness[j, i]
                if k == n_layers:
                    zeta[k, j, i] = b + h
                elif h >= full:
                    zeta[k, j, i] = b + k * (h / n_layers)
                else:
                    zeta[k, j, i] = b + min(k * dz_min, h)
    return zeta


@numba.njit(cache=True)
def dof_map(zeta, active, frozen):
    """(dof int64[N + 1, ny, nx], count) of ``lattice.dof_map``: the free nodes numbered in the
    order of the flattened lattice (level, row, column), nodes above a column's last
    non-collapsed level sharing its number, −1 for nodes held at zero."""
    nz, ny, nx = zeta.shape
    top = np.zeros((ny, nx), dtype=np.int64)  # non-collapsed layers per column
    for k in range(nz - 1):
        for j in range(ny):
            for i in range(nx):
                if zeta[k + 1, j, i] - zeta[k, j, i] > 0:
                    top[j, i] += 1
    dof = np.empty((nz, ny, nx), dtype=np.int64)
    count = 0
    for k in range(nz):  # level by level, so a collapsed node's own column level is numbered
        for j in range(ny):
            for i in range(nx):
                m = top[j, i]
                if k > m:
                    dof[k, j, i] = dof[m, j, i]
                elif active[j, i] and not (frozen[j, i] and k == 0):
                    dof[k, j, i] = count
                    count += 1
                else:
                    dof[k, j, i] = -1
    return dof, count
