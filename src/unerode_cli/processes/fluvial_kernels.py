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
    slope_to,
    spread,
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


@numba.njit(cache=True)
def slope_into(h, valid, dx, dy, mode, s):
    """``slope_magnitude`` into ``s`` (float64[ny*nx], any content on entry)."""
    ny, nx = h.shape
    for r in range(ny):
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


@numba.njit(cache=True, inline="always")
def _spread_pair_mfd(flux, z, i, h, off, inv_dist, q, qs):
    """Multiple flow directions at an interior cell ``i``: ``flux[j, 0] += frac·q`` and
    ``flux[j, 1] += frac·qs`` for the 8 neighbours j, with the fractions of
    ``unerode_cli.hydro.kernels.flow_fractions`` (000 Eq. 6) computed by the same operations
    in the same order (bit-identical shares; see ``spread_mfd``)."""
    s0 = slope_to(z, h, i + off[0], inv_dist[0])
    s1 = slope_to(z, h, i + off[1], inv_dist[1])
    s2 = slope_to(z, h, i + off[2], inv_dist[2])
    s3 = slope_to(z, h, i + off[3], inv_dist[3])
    s4 = slope_to(z, h, i + off[4], inv_dist[4])
    s5 = slope_to(z, h, i + off[5], inv_dist[5])
    s6 = slope_to(z, h, i + off[6], inv_dist[6])
    s7 = slope_to(z, h, i + off[7], inv_dist[7])
    total = 0.0 + s0 + s1 + s2 + s3 + s4 + s5 + s6 + s7
    scale = 1.0 / total if total > 0.0 else 0.0
    f = s0 * scale
    flux[i + off[0], 0] += f * q
    flux[i + off[0], 1] += f * qs
    f = s1 * scale
    flux[i + off[1], 0] += f * q
    flux[i + off[1], 1] += f * qs
    f = s2 * scale
    flux[i + off[2], 0] += f * q
    flux[i + off[2], 1] += f * qs
    f = s3 * scale
    flux[i + off[3], 0] += f * q
    flux[i + off[3], 1] += f * qs
    f = s4 * scale
    flux[i + off[4], 0] += f * q
    flux[i + off[4], 1] += f * qs
    f = s5 * scale
    flux[i + off[5], 0] += f * q
    flux[i + off[5], 1] += f * qs
    f = s6 * scale
    flux[i + off[6], 0] += f * q
    flux[i + off[6], 1] += f * qs
    f = s7 * scale
    flux[i + off[7], 0] += f * q
    flux[i + off[7], 1] += f * qs


@numba.njit(cache=True)
def fluvial_sweep(zf, outlets, order, dx, dy, single, slope, precipitation, uplift, k, k_d, m, n, dt):
    """One step of 000 Eq. 8 in a single pass over the cells, donors first (000 Algorithm 1).

    At each cell p, with every donor already done:
      Q(p)  = p(p)·A + Σ_donors α·Q                       (000 Eq. 5, m³/y; A = dx·dy)
      Q̃s(p) = Σ_donors α·Qs                               (m³/y)
      E     = K·Q^m·|∇h|^n                                 (erosion rate, m/y)
      D     = min(K_d·Q̃s/Q, Q̃s/A)                         (deposition rate, m/y)
      Δh    = dt·(U − E + D)                               (000 Eq. 8)
      Qs(p) = (U − Δh/dt)·A + Q̃s = (E − D)·A + Q̃s ≥ 0      (000 Eq. 7)
    D is capped at what arrives (Q̃s/A) so that Qs is never negative. Outlets keep their
    elevation (Δh = 0, no uplift) and pass on what arrives: Qs = Q̃s.

    Args:
        zf, outlets, order, dx, dy, single: the routing (see ``unerode_cli.hydro.kernels``).
        slope: float64[ny*nx] |∇h| at time t (m/m).
        precipitation, uplift, k, k_d: fields p (m/y), U (m/y), K (m^(1−3m)·y^(m−1)),
            K_d (m/y).
        m, n: stream power exponents; dt: time step (y), negative backward in time.

    Returns:
        (dh float64[ny*nx] (m), Q float64[ny*nx] (m³/y), Qs float64[ny*nx] (m³/y),
         Σ max(0, E − D)·A, Σ max(0, D − E)·A over free cells and Σ Q̃s over outlets, m³/y).
    """
    size = zf.size
    dh = np.zeros(size, dtype=np.float64)
    # Q and Qs side by side: the sweep reads and writes both at the same cells.
    flux = np.zeros((size, 2), dtype=np.float64)
    rates = fluvial_sweep_into(
        zf, outlets, order, dx, dy, single, slope, precipitation, uplift, k, k_d, m, n, dt, dh, flux
    )
    return dh, flux[:, 0], flux[:, 1], rates[0], rates[1], rates[2]


@numba.njit(cache=True)
def fluvial_sweep_into(
    zf, outlets, order, dx, dy, single, slope, precipitation, uplift, k, k_d, m, n, dt, dh, flux
):
    """``fluvial_sweep`` into arrays given by the caller: ``dh`` float64[ny*nx] and ``flux``
    float64[ny*nx, 2] (Q, Qs), both all 0 on entry. Interior cells spread Q and Qs with
    ``steepest_of`` / ``_spread_pair_mfd``, the others with ``flow_fractions``: the same
    shares.

    Returns:
        (Σ max(0, E − D)·A, Σ max(0, D − E)·A, Σ Q̃s over outlets), m³/y.
    """
    ny, nx = zf.shape
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    area = dx * dy
    inv_nx = 1.0 / nx
    frac = np.empty(8, dtype=np.float64)
    erosion_rate = 0.0
    deposition_rate = 0.0
    outflow_rate = 0.0
    for idx in range(order.size):
        i = order[idx]
        qi = flux[i, 0] + _at(precipitation, i) * area
        flux[i, 0] = qi
        arriving = flux[i, 1]
        if out[i]:
            outflow_rate += arriving
            continue
        s = slope[i]
        erosion = 0.0
        if qi > 0.0 and s > 0.0:
            erosion = _at(k, i) * qi**m * (s if n == 1.0 else s**n)
        deposition = 0.0
        if arriving > 0.0:
            deposition = min(_at(k_d, i) * arriving / qi, arriving / area)
        net = erosion - deposition
        dh[i] = dt * (_at(uplift, i) - net)
        leaving = max(arriving + net * area, 0.0)
        flux[i, 1] = leaving
        erosion_rate += max(net, 0.0) * area
        deposition_rate += max(-net, 0.0) * area
        r = row_of(i, inv_nx)
        col = i - r * nx
        if 0 < r < ny - 1 and 0 < col < nx - 1:
            if single:
                best = steepest_of(z, i, z[i], off, inv_dist)
                if best >= 0:
                    flux[i + off[best], 0] += qi
                    flux[i + off[best], 1] += leaving
            else:
                _spread_pair_mfd(flux, z, i, z[i], off, inv_dist, qi, leaving)
        else:
            interior = flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
            spread(flux, i, off, frac, (qi, leaving), interior)
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
