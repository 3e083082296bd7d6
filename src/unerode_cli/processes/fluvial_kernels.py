"""Numba kernels of fluvial erosion, deposition and their reversal (000 §3).

Fields (uplift, erodibility, ...) are flat float64 arrays of size ny*nx, or of size 1 for a
value that is the same everywhere.
"""

from __future__ import annotations

import numba
import numpy as np

from unerode_cli.hydro.kernels import (
    flow_fractions,
    inverse_distances,
    neighbour_offsets,
    row_of,
    spread,
    spread_mfd,
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


@numba.njit(cache=True)
def slope_magnitude(h, valid, dx, dy, mode):
    """|∇h| = sqrt(gx² + gy²) (m/m) of every valid cell, per-axis magnitudes from
    ``_axis_gradient``; a neighbour off the grid or on nodata counts as the cell itself.

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
            if not valid[r, c]:
                s[r * nx + c] = 0.0
                continue
            h0 = h[r, c]
            he = h[r, c + 1] if c + 1 < nx and valid[r, c + 1] else h0
            hw = h[r, c - 1] if c > 0 and valid[r, c - 1] else h0
            hs = h[r + 1, c] if r + 1 < ny and valid[r + 1, c] else h0
            hn = h[r - 1, c] if r > 0 and valid[r - 1, c] else h0
            gx = _axis_gradient(h0, he, hw, dx, mode)
            gy = _axis_gradient(h0, hs, hn, dy, mode)
            s[r * nx + c] = np.sqrt(gx * gx + gy * gy)


@numba.njit(cache=True, parallel=True)
def local_rates_into(q, slope, k, k_d, m, n, erosion, trapping):
    """The per-cell terms of 000 Eq. 8 that do not depend on the sediment flux, in parallel.

      erosion[i]  = E = K·Q^m·|∇h|^n      (m/y; 0 where Q or |∇h| is 0)
      trapping[i] = K_d/Q                 (1/m²; the deposition rate is D = Q̃s·K_d/Q, Eq. 7)

    where Q is 0 and K_d > 0, ``trapping`` is +inf (whatever arrives is deposited, up to the
    cap of ``sediment_sweep_into``).

    Args:
        q: float64[ny*nx] discharge Q (m³/y); slope: float64[ny*nx] |∇h| (m/m).
        k, k_d: fields K (m^(1−3m)·y^(m−1)) and K_d (m/y).
        m, n: stream power exponents.
        erosion, trapping: float64[ny*nx] outputs (any content on entry).
    """
    for i in numba.prange(q.size):
        qi = q[i]
        s = slope[i]
        e = 0.0
        if qi > 0.0 and s > 0.0:
            e = _at(k, i) * qi**m * (s if n == 1.0 else s**n)
        erosion[i] = e
        kd = _at(k_d, i)
        trapping[i] = kd / qi if qi > 0.0 else (np.inf if kd > 0.0 else 0.0)


@numba.njit(cache=True)
def sediment_sweep_into(zf, outlets, order, dx, dy, single, erosion, trapping, uplift, dt, dh, qs):
    """One step of 000 Eq. 8 in a single pass over the cells, donors first (000 Algorithm 1),
    given the local terms of ``local_rates_into``. At each cell p, with every donor done:

      Q̃s    = Σ_donors α·Qs                        (m³/y, arriving sediment flux)
      D     = Q̃s·min(K_d/Q, 1/A)                  (deposition rate, m/y; A = dx·dy)
      Δh    = dt·(U − E + D)                       (000 Eq. 8)
      Qs(p) = Q̃s + (E − D)·A ≥ 0                   (000 Eq. 7)

    D is capped at what arrives (Q̃s/A) so that Qs is never negative. Outlets keep their
    elevation (Δh = 0, no uplift) and pass on nothing: their Qs is what leaves the domain.

    Args:
        zf, outlets, order, dx, dy, single: the routing (see ``unerode_cli.hydro.kernels``).
        erosion, trapping: float64[ny*nx] E (m/y) and K_d/Q (1/m²).
        uplift: field U (m/y); dt: time step (y), negative backward in time.
        dh: float64[ny*nx] set to Δh (m) on the valid non-outlet cells (others untouched).
        qs: float64[ny*nx], all 0 on entry, set to Qs (m³/y).

    Returns:
        (Σ max(0, E − D)·A, Σ max(0, D − E)·A over free cells and Σ Q̃s over outlets), m³/y.
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
    erosion_rate = 0.0
    deposition_rate = 0.0
    outflow_rate = 0.0
    for idx in range(order.size):
        i = order[idx]
        arriving = qs[i]
        if out[i]:
            outflow_rate += arriving
            continue
        net = erosion[i] - arriving * min(trapping[i], inv_area)
        dh[i] = dt * (_at(uplift, i) - net)
        leaving = max(arriving + net * area, 0.0)
        qs[i] = leaving
        erosion_rate += max(net, 0.0) * area
        deposition_rate += max(-net, 0.0) * area
        # The same shares as ``accumulate_into`` (one-pass paths for interior cells).
        r = row_of(i, inv_nx)
        col = i - r * nx
        if 0 < r < ny - 1 and 0 < col < nx - 1:
            if single:
                best = steepest_of(z, i, z[i], off, inv_dist)
                if best >= 0:
                    qs[i + off[best]] += leaving
            else:
                spread_mfd(qs, z, i, z[i], off, inv_dist, leaving)
        else:
            interior = flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
            spread(qs, i, off, frac, leaving, interior)
    return erosion_rate, deposition_rate, outflow_rate


@numba.njit(cache=True)
def max_speed(q, slope, free, k, m, n):
    """Largest n·K·Q^m·|∇h|^(n−1) over the ``free`` cells (m/y): the speed at which the stream
    power term of 000 Eq. 1 carries elevation changes upstream (cells of zero slope are left
    out when n ≠ 1)."""
    speed = 0.0
    for i in range(q.size):
        if not free[i] or q[i] <= 0.0:
            continue
        s = slope[i]
        if n != 1.0 and s <= 0.0:
            continue
        c = n * _at(k, i) * q[i] ** m * (1.0 if n == 1.0 else s ** (n - 1.0))
        speed = max(speed, c)
    return speed
