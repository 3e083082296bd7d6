"""Numba kernels of the horizontal coarse-grid correction of ``blatter``'s multigrid (001 Eq. 7's
minimisation).

A coarse lattice keeps every ``fy``-th row and ``fx``-th column of nodes (f = 1 or 2 per axis) and
the same levels k. Prolongation P: bilinear interpolation of the coarse node values along each
coarsened axis (a fine node between two coarse nodes takes their mean; past the last coarse node of
an open axis, its value), level by level. A fine unknown takes the value interpolated at its lowest
node (the node it is stored at; collapsed nodes above share it). Restriction of a gradient: Pᵀ.
Velocities in m/y, unknowns x = [u_dof, v_dof] as in ``blatter_energy``.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _weights(i, f, nc, periodic):
    """Coarse neighbours (i0, i1) and weights (w0, w1) of fine index i along an axis coarsened by f
    (1 or 2) to nc coarse nodes (w1 = 0 when there is one)."""
    if f == 1:
        return i, i, 1.0, 0.0
    i0 = i // 2
    if i - 2 * i0 == 0:
        return i0, i0, 1.0, 0.0
    i1 = i0 + 1
    if i1 >= nc:
        if periodic:
            return i0, 0, 0.5, 0.5
        return i0, i0, 1.0, 0.0
    return i0, i1, 0.5, 0.5


@numba.njit(cache=True)
def transfer_entries(dof_f, dof_c, fy, fx, periodic):
    """The bilinear prolongation P as entries (fine unknown, coarse unknown, weight), int64[E],
    int64[E], float64[E], in the order of the fine nodes: P·y and Pᵀ·g both read them."""
    nz, ny, nx = dof_f.shape
    ncy, ncx = dof_c.shape[1], dof_c.shape[2]
    fine = np.empty(4 * dof_f.size, dtype=np.int64)
    coarse = np.empty(4 * dof_f.size, dtype=np.int64)
    weight = np.empty(4 * dof_f.size)
    e = 0
    for k in range(nz):
        for j in range(ny):
            j0, j1, wy0, wy1 = _weights(j, fy, ncy, periodic)
            for i in range(nx):
                d = dof_f[k, j, i]
                if d < 0 or (k > 0 and dof_f[k - 1, j, i] == d):
                    continue
                i0, i1, wx0, wx1 = _weights(i, fx, ncx, periodic)
                for b in range(2):
                    jj, wy = (j1, wy1) if b else (j0, wy0)
                    if wy == 0.0:
                        continue
                    for a in range(2):
                        ii, wx = (i1, wx1) if a else (i0, wx0)
                        if wx == 0.0:
                            continue
                        c = dof_c[k, jj, ii]
                        if c >= 0:
                            fine[e], coarse[e], weight[e] = d, c, wy * wx
                            e += 1
    return fine[:e], coarse[:e], weight[:e]


@numba.njit(cache=True)
def prolong(y, entries, n_f):
    """Fine unknowns (float64[2 n_f]) interpolated from the coarse unknowns y by P, given as
    ``transfer_entries``."""
    fine, coarse, weight = entries
    n_c = y.size // 2
    x = np.zeros(2 * n_f)
    for e in range(fine.size):
        x[fine[e]] += weight[e] * y[coarse[e]]
        x[n_f + fine[e]] += weight[e] * y[n_c + coarse[e]]
    return x


@numba.njit(cache=True)
def restrict_gradient(g, entries, n_c):
    """Pᵀ·g (P as ``transfer_entries``): the gradient with respect to the coarse unknowns of
    E(P·y), float64[2 n_c]."""
    fine, coarse, weight = entries
    n_f = g.size // 2
    out = np.zeros(2 * n_c)
    for e in range(fine.size):
        out[coarse[e]] += weight[e] * g[fine[e]]
        out[n_c + coarse[e]] += weight[e] * g[n_f + fine[e]]
    return out


@numba.njit(cache=True)
def inject(x, dof_f, dof_c, n_c, fy, fx):
    """Coarse unknowns (float64[2 n_c]) taking the fine values at the coarse nodes (0 where the fine
    node has none)."""
    nz, ncy, ncx = dof_c.shape
    n_f = x.size // 2
    y = np.zeros(2 * n_c)
    for k in range(nz):
        for j in range(ncy):
            for i in range(ncx):
                c = dof_c[k, j, i]
                if c < 0 or (k > 0 and dof_c[k - 1, j, i] == c):
                    continue
                d = dof_f[k, j * fy, i * fx]
                if d >= 0:
                    y[c] = x[d]
                    y[n_c + c] = x[n_f + d]
    return y
