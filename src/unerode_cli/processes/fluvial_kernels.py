"""Numba kernels of fluvial erosion, deposition and their reversal (000 §3).

Fields (uplift, erodibility, ...) are flat float64 arrays of size ny*nx, or of size 1 for a
value that is the same everywhere.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.hydro.kernels import (
    flow_fractions,
    inverse_distances,
    neighbour_offsets,
    row_of,
    spread,
    spread_mfd_pair,
    steepest_of,
)

DOWNSTREAM = 0
UPWIND = 1
LIMITED = 2


@numba.njit(cache=True, inline="always")
def _at(field, i):
    """Value of a scalar-or-raster field at flat index ``i``."""
    return field[0] if field.size == 1 else field[i]


@numba.njit(cache=True, inline="always")
def _axis_gradient(h0, ha, hb, d, mode):
    """Gradient magnitude along one axis from the cell (h0) and its two neighbours (m).

    DOWNSTREAM: 000 Eq. 9, max(0, h0 - ha, h0 - hb) / d.
    UPWIND: 000 Eq. 10, max(0, ha - h0, hb - h0) / d.
    LIMITED: 000 Eq. 12, the upwind magnitude blended towards the centred one |ha - hb| / 2d
    (000 Eq. 11) by the minmod limiter φ(r) = clamp(r, 0, 1), r = downstream / upwind; 0
    where the upwind magnitude is 0.
    """
    down = max(0.0, h0 - ha, h0 - hb) / d
    if mode == DOWNSTREAM:
        return down
    up = max(0.0, ha - h0, hb - h0) / d
    if mode == UPWIND or up == 0.0:
        return up
    phi = min(down / up, 1.0)
    return up - phi * (up - abs(ha - hb) / (2.0 * d))


def slope_magnitude(h, valid, dx, dy, mode):
    """|∇h| = sqrt(gx² + gy²) (m/m) of every valid cell, per-axis magnitudes from
    ``_axis_gradient``; a neighbour off the grid or on nodata counts as the cell itself.

    A plain function around the parallel ``slope_into``: a cached kernel that calls a cached
    parallel kernel can crash when it is loaded back from numba's on-disk cache.

    Args:
        h: float64[ny, nx] elevation (m), row 0 = north.
        valid: bool[ny, nx] domain mask.
        dx, dy: east-west and north-south cell sizes (m).
        mode: DOWNSTREAM, UPWIND or LIMITED.

    Returns:
        float64[ny*nx], 0 on nodata.
    """
    s = np.empty(h.size, dtype=np.float64)
    slope_into(h, valid, dx, dy, mode, s)
    return s


@numba.njit(cache=True, parallel=True)
def slope_into(h, valid, dx, dy, mode, s):
    """``slope_magnitude`` into ``s`` (float64[ny*nx], any content on entry); rows in parallel."""
    ny, nx = h.shape
    for r in numba.prange(ny):
        for c in range(nx):
            s[r * nx + c] = cell_slope(h, valid, r, c, dx, dy, mode) if valid[r, c] else 0.0


@numba.njit(cache=True, inline="always")
def cell_slope(h, valid, r, c, dx, dy, mode):
    """``slope_magnitude`` of the valid cell (r, c) of ``h`` (float64[ny, nx], m) (m/m)."""
    ny, nx = h.shape
    h0 = h[r, c]
    he = h[r, c + 1] if c + 1 < nx and valid[r, c + 1] else h0
    hw = h[r, c - 1] if c > 0 and valid[r, c - 1] else h0
    hs = h[r + 1, c] if r + 1 < ny and valid[r + 1, c] else h0
    hn = h[r - 1, c] if r > 0 and valid[r - 1, c] else h0
    gx = _axis_gradient(h0, he, hw, dx, mode)
    gy = _axis_gradient(h0, hs, hn, dy, mode)
    return np.sqrt(gx * gx + gy * gy)


@numba.njit(cache=True, parallel=True)
def erodibility_into(order, slope, k, n, coef):
    """coef[p] = K·|∇h|^n (m/y per (m³/y)^m) of cell ``order[p]``, in parallel: the part of
    the stream power term E = K·Q^m·|∇h|^n (000 Eq. 1) that does not depend on the discharge,
    laid out by position in ``order`` so that the serial sweep reads it in sequence.

    Args:
        order: flat indices of the cells, donors first (``Routing.order``).
        slope: float64[ny*nx] |∇h| (m/m); k: field K (m^(1−3m)·y^(m−1)); n: slope exponent.
        coef: float64[order.size] output (any content on entry).
    """
    for p in numba.prange(order.size):
        i = order[p]
        s = slope[i]
        coef[p] = _at(k, i) * (s if n == 1.0 else (s**n if s > 0.0 else 0.0))


@numba.njit(cache=True)
def fluvial_sweep_into(zf, outlets, order, dx, dy, single, source, coef, k_d, m, q, qs, net):
    """Discharge and sediment flux of one step of 000 Eq. 8 in a single pass over the cells,
    donors first (000 Algorithm 1). At each cell p, with every donor done:

      Q     = source + Σ_donors α·Q                 (m³/y, 000 Eq. 5)
      Q̃s    = Qs,in + Σ_donors α·Qs                (m³/y, arriving sediment flux)
      E     = K·|∇h|^n·Q^m                          (m/y, 000 Eq. 1)
      D     = Q̃s·min(K_d/Q, 1/A)                  (deposition rate, m/y; A = dx·dy)
      Qs(p) = Q̃s + (E − D)·A ≥ 0                   (000 Eq. 7)

    D is capped at what arrives (Q̃s/A) so that Qs is never negative; where Q is 0 and
    K_d > 0 the cap applies. Water and sediment go to the receivers with the same shares as
    ``unerode_cli.hydro.kernels.accumulate_into``. Outlets pass on nothing: their Q and Qs are
    what leaves the domain there. ``settle_into`` turns E − D into Δh.

    Args:
        zf, outlets, order, dx, dy, single: the routing (see ``unerode_cli.hydro.kernels``).
        source: float64[ny*nx] p·A per cell (m³/y), or float64[1] for the same everywhere.
        coef: float64[order.size] K·|∇h|^n by position in ``order`` (``erodibility_into``).
        k_d: field K_d (m/y); m: discharge exponent.
        q: float64[ny*nx], all 0 on entry, set to Q (m³/y).
        qs: float64[ny*nx], on entry the sediment flux entering each cell from outside the
            domain (m³/y, 0 where none: 000 §6.3.1), set to Qs (m³/y).
        net: float64[order.size] set to E − D (m/y) by position in ``order`` (outlets: left
            as they were).
    """
    ny, nx = zf.shape
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    area = dx * dy
    inv_area = 1.0 / area
    inv_nx = 1.0 / nx
    frac = np.empty(8, dtype=np.float64)
    uniform = source.size == 1
    for idx in range(order.size):
        i = order[idx]
        water = q[i] + (source[0] if uniform else source[i])
        q[i] = water
        if out[i]:
            continue
        arriving = qs[i]
        c = coef[idx]
        kd = _at(k_d, i)
        if water > 0.0:
            # Q^m as 2^(m·log2 Q): a few ulps from pow, and a third cheaper on this serial path.
            erosion = c * math.exp2(m * math.log2(water)) if c > 0.0 else 0.0
            trapping = min(kd / water, inv_area)
        else:
            erosion = 0.0
            trapping = inv_area if kd > 0.0 else 0.0
        rate = erosion - arriving * trapping
        net[idx] = rate
        leaving = max(arriving + rate * area, 0.0)
        qs[i] = leaving
        r = row_of(i, inv_nx)
        col = i - r * nx
        if 0 < r < ny - 1 and 0 < col < nx - 1:
            if single:
                best = steepest_of(z, i, z[i], off, inv_dist)
                if best >= 0:
                    q[i + off[best]] += water
                    qs[i + off[best]] += leaving
            else:
                spread_mfd_pair(q, water, qs, leaving, z, i, z[i], off, inv_dist)
        else:
            interior = flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
            spread(q, i, off, frac, water, interior)
            spread(qs, i, off, frac, leaving, interior)


#: Cells of ``order`` per block of :func:`settle_into`'s sums: the blocks depend on the number of
#: cells only, never on the number of threads.
SETTLE_BLOCK = 16384


@numba.njit(cache=True, parallel=True)
def settle_into(order, net, qs, outlets, uplift, dt, area, dh):
    """Elevation change and mass budget of a step after ``fluvial_sweep_into``:

      Δh = dt·(U − (E − D))                         (000 Eq. 8)

    on the cells of ``order`` that are not outlets (outlets keep their elevation: no uplift),
    in parallel. The budget is summed in fixed blocks of :data:`SETTLE_BLOCK` consecutive cells
    of ``order`` (each block in order, on any thread), then block after block, so that it is the
    same to the last bit whatever the number of threads and their scheduling.

    Args:
        order: flat indices of the cells (``Routing.order``).
        net: float64[order.size] E − D (m/y) by position in ``order``.
        qs: float64[ny*nx] sediment flux Qs (m³/y).
        outlets: bool[ny*nx] outlets.
        uplift: field U (m/y); dt: time step (y), negative backward in time.
        area: cell area (m²).
        dh: float64[ny*nx] set to Δh (m) on the cells of ``order`` that are not outlets.

    Returns:
        (Σ max(0, E − D)·A and Σ max(0, D − E)·A over those cells, Σ Qs over outlets), m³/y.
    """
    blocks = (order.size + SETTLE_BLOCK - 1) // SETTLE_BLOCK
    sums = np.zeros((blocks, 3))
    for b in numba.prange(blocks):
        eroded = 0.0
        deposited = 0.0
        outflow = 0.0
        for p in range(b * SETTLE_BLOCK, min((b + 1) * SETTLE_BLOCK, order.size)):
            i = order[p]
            if outlets[i]:
                outflow += qs[i]
                continue
            rate = net[p]
            dh[i] = dt * (_at(uplift, i) - rate)
            eroded += max(rate, 0.0) * area
            deposited += max(-rate, 0.0) * area
        sums[b, 0] = eroded
        sums[b, 1] = deposited
        sums[b, 2] = outflow
    eroded = 0.0
    deposited = 0.0
    outflow = 0.0
    for b in range(blocks):
        eroded += sums[b, 0]
        deposited += sums[b, 1]
        outflow += sums[b, 2]
    return eroded, deposited, outflow


@numba.njit(cache=True, parallel=True)
def max_speed(q, slope, free, k, m, n):
    """Largest n·K·Q^m·|∇h|^(n−1) over the ``free`` cells (m/y), in parallel: the speed at
    which the stream power term of 000 Eq. 1 carries elevation changes upstream (cells of zero
    slope are left out when n ≠ 1). With one K and n = 1 that is K·(max Q)^m: one power."""
    speed = 0.0
    if k.size == 1 and n == 1.0:
        q_max = 0.0
        for i in numba.prange(q.size):
            if free[i]:
                q_max = max(q_max, q[i])
        return k[0] * q_max**m if q_max > 0.0 else 0.0
    for i in numba.prange(q.size):
        s = slope[i]
        if free[i] and q[i] > 0.0 and (n == 1.0 or s > 0.0):
            speed = max(speed, n * _at(k, i) * q[i] ** m * (1.0 if n == 1.0 else s ** (n - 1.0)))
    return speed
