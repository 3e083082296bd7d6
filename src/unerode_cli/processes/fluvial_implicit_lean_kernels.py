"""The implicit forward fluvial step on cell-indexed arrays: the lean layout.

The same equations, passes and iteration as ``fluvial_implicit_kernels.implicit_sweep_into``
(Braun & Willett 2013; Yuan et al. 2019, §3.2; see there), but nothing is laid out in the
routing's order: each pass reads its cells where they lie and works out each cell's receivers
and flow fractions again from the routing surface (000 Eq. 6). Besides its inputs and outputs
the step holds one float32 grid (K·Q^m·dt), against about 60 bytes a cell of the laid-out
kernel's in-order copies and receiver lists; each pass costs more (scattered reads, the
fractions computed again), so the process takes it where the laid-out one would not fit.

Fields (uplift, erodibility, K_d) are flat float64 arrays of size ny*nx, or of size 1 for a
value that is the same everywhere.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.hydro.kernels import flow_fractions, inverse_distances, neighbour_offsets
from unerode_cli.processes.fluvial_implicit_kernels import _leaving, _relaxation, solve_cell
from unerode_cli.processes.fluvial_kernels import DOWNSTREAM, _at, cell_slope


@numba.njit(cache=True)
def lean_sweep_into(h0, valid, zf, outlets, order, dx, dy, single, q, k, n, m, k_d, uplift, dt, qs_in,
                    rtol, atol, max_iter, hn, qs, dep, coef):
    """One implicit forward step of 000 Eq. 3 (dt > 0) on cell-indexed arrays.

    Args:
        h0: float64[ny, nx] elevation at the start (m); valid: bool[ny, nx] the domain.
        zf, outlets, order, dx, dy, single: the routing of ``h0`` (``unerode_cli.hydro``).
        q: float[ny*nx] discharge Q (m³/y).
        k, n, m, k_d, uplift, dt, qs_in, rtol, atol, max_iter: as for
            ``fluvial_implicit_kernels.implicit_sweep_into``.
        hn: float64[ny*nx] set to the elevation at the end of the step (outlets: h0).
        qs: float64[ny*nx] set to the sediment flux leaving each cell (m³/y).
        dep: float64[ny*nx] deposition rates D (m/y): the first guess on entry, the last
            pass's on return (float64: the iteration's tolerance is a share of the step's
            largest |Δh|, far below the rounding of D·dt in float32 near a steady state).
        coef: float[ny*nx] scratch, set to K·Q^m·dt (MFD: scaled to 000 Eq. 9's gradient).

    Returns:
        as ``implicit_sweep_into``: (passes, residual ÷ tolerance, volume rate set to 0 on
        negative fluxes, erosion, deposition and outflux rates (m³/y)).
    """
    ny, nx = zf.shape
    z = zf.ravel()
    h = h0.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    area = dx * dy
    depositing = _coefficients(h0, valid, z, out, order, ny, nx, off, inv_dist, single, q, k, n, m, k_d,
                               dt, dx, dy, hn, coef)
    passes = 0
    ratio = 0.0
    clipped = 0.0
    eroded = 0.0
    deposited = 0.0
    relax = 1.0
    previous = math.inf
    stalled = 0
    for _ in range(max_iter):
        passes += 1
        _receivers_pass(h, z, out, order, ny, nx, off, inv_dist, single, uplift, dt, hn, dep, coef, n)
        change, largest, clipped, eroded, deposited = _sediment_pass(
            h, z, out, order, ny, nx, off, inv_dist, single, q, k_d, uplift, dt, qs_in, depositing, relax,
            area, hn, dep, coef, qs, n)
        tol = max(atol, rtol * largest)
        ratio = change / tol
        if change <= tol:
            break
        previous, stalled, relax = _relaxation(change, previous, stalled, relax)
    outflow = 0.0
    for p in range(order.size):
        if out[order[p]]:
            outflow += qs[order[p]]
    return passes, ratio, clipped, eroded, deposited, outflow


@numba.njit(cache=True)
def _coefficients(h0, valid, z, out, order, ny, nx, off, inv_dist, single, q, k, n, m, k_d, dt, dx, dy,
                  hn, coef):
    """hn = h0 and coef = K·Q^m·dt of every cell of the order (MFD: times c^n, c = |∇h| ÷ the
    weighted receiver slope, as the laid-out kernel); 0 on outlets and under a lake of the
    routing surface. Returns whether any K_d > 0."""
    h = h0.ravel()
    frac = np.empty(8, dtype=np.float64)
    depositing = False
    for p in range(order.size):
        i = order[p]
        hn[i] = h[i]
        depositing = depositing or _at(k_d, i) > 0.0
        coef[i] = 0.0
        water = q[i]
        if out[i] or not water > 0.0 or z[i] > h[i]:
            continue
        c = _at(k, i) * math.exp2(m * math.log2(water)) * dt
        if not single:
            flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
            weighted = 0.0
            for kk in range(8):
                if frac[kk] > 0.0:
                    weighted += frac[kk] * inv_dist[kk] * max(h[i] - h[i + off[kk]], 0.0)
            if weighted > 0.0:
                r = i // nx
                ratio = cell_slope(h0, valid, r, i - r * nx, dx, dy, DOWNSTREAM) / weighted
                c *= ratio if n == 1.0 else ratio**n
        coef[i] = c
    return depositing


@numba.njit(cache=True, inline="always")
def _gather(z, hn, i, ny, nx, off, inv_dist, single, frac, hr, a):
    """The receivers of cell ``i``: fractions into ``frac``, their elevations (from ``hn``) into
    ``hr``, weights w_k / L_k into ``a``; returns their count."""
    flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
    count = 0
    for kk in range(8):
        if frac[kk] > 0.0:
            hr[count] = hn[i + off[kk]]
            a[count] = frac[kk] * inv_dist[kk]
            count += 1
    return count


@numba.njit(cache=True)
def _receivers_pass(h, z, out, order, ny, nx, off, inv_dist, single, uplift, dt, hn, dep, coef, n):
    """Receivers first: each cell solved from its receivers' end-of-step elevations."""
    frac = np.empty(8, dtype=np.float64)
    hr = np.empty(8, dtype=np.float64)
    a = np.empty(8, dtype=np.float64)
    for p in range(order.size - 1, -1, -1):
        i = order[p]
        if out[i]:
            continue
        count = _gather(z, hn, i, ny, nx, off, inv_dist, single, frac, hr, a)
        hn[i] = solve_cell(h[i] + dt * (_at(uplift, i) + dep[i]), hr, a, count, coef[i], n)


@numba.njit(cache=True)
def _sediment_pass(h, z, out, order, ny, nx, off, inv_dist, single, q, k_d, uplift, dt, qs_in, depositing,
                   relax, area, hn, dep, coef, qs, n):
    """Donors first: the sediment arriving sets the deposition rate (000 Eq. 8, capped at what
    arrives, relaxed by ``relax``), the cell is solved again with it, and what it lost goes on
    to its receivers by their fractions. Returns (largest change of D·dt (m), largest |Δh|
    (m), volume rate set to 0 on negative fluxes, erosion and deposition rates (m³/y))."""
    frac = np.empty(8, dtype=np.float64)
    hr = np.empty(8, dtype=np.float64)
    a = np.empty(8, dtype=np.float64)
    inv_area = 1.0 / area
    change = 0.0
    clipped = 0.0
    largest = 0.0
    eroded = 0.0
    deposited = 0.0
    for p in range(order.size):
        i = order[p]
        qs[i] = qs_in[i] if qs_in.size > 1 else 0.0
    for p in range(order.size):
        i = order[p]
        if out[i]:
            continue
        arriving = qs[i]
        u = _at(uplift, i)
        count = _gather(z, hn, i, ny, nx, off, inv_dist, single, frac, hr, a)
        if depositing:
            water = q[i]
            kd = _at(k_d, i)
            trap = min(kd / water, inv_area) if water > 0.0 else (inv_area if kd > 0.0 else 0.0)
            fresh = arriving * trap
            change = max(change, abs(fresh - dep[i]) * dt)
            dep[i] += relax * (fresh - dep[i])
            hn[i] = solve_cell(h[i] + dt * (u + dep[i]), hr, a, count, coef[i], n)
        leaving, step, lost = _leaving(arriving, u, h[i], hn[i], dt, area)
        largest = max(largest, abs(step))
        eroded += max(lost, 0.0)
        deposited += max(-lost, 0.0)
        clipped += max(-leaving, 0.0)
        leaving = max(leaving, 0.0)
        qs[i] = leaving
        for kk in range(8):
            if frac[kk] > 0.0:
                qs[i + off[kk]] += frac[kk] * leaving
    return change, largest, clipped, eroded, deposited
