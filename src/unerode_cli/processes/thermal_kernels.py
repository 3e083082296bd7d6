"""Numba kernels of thermal erosion, deposition and their reversal (000 §4), and of the classic
cellular automaton of Musgrave, Kolb & Mace (1989) kept for comparison (000 Fig. 3).

Fields (erodibility K_th, ...) are flat float64 arrays of size ny*nx, or of size 1 for a value
that is the same everywhere.
"""

from __future__ import annotations

import numba
import numpy as np

from unerode_cli.hydro.kernels import flow_fractions, inverse_distances, neighbour_offsets, spread

#: Un-deposition constraints of backward steps (bit flags).
SLOPE_LIMIT = 1  # 000 Eq. 16
CONVEXITY = 2  # 000 Eq. 17
RATE_LIMIT = 4  # maximal un-deposition rate


@numba.njit(cache=True, inline="always")
def _at(field, i):
    """Value of a scalar-or-raster field at flat index ``i``."""
    return field[0] if field.size == 1 else field[i]


@numba.njit(cache=True, inline="always")
def _uphill_axis(h, valid, r, c, dr, dc, ny, nx):
    """Upwind gradient (m, not divided by the cell size) along one axis and the direction
    (+1/−1, 0 when neither neighbour is higher) of the higher neighbour."""
    h0 = h[r, c]
    best, sign = 0.0, 0
    for s in (1, -1):
        rr, cc = r + s * dr, c + s * dc
        if 0 <= rr < ny and 0 <= cc < nx and valid[rr, cc] and h[rr, cc] - h0 > best:
            best, sign = h[rr, cc] - h0, s
    return best, sign


@numba.njit(cache=True, inline="always")
def _inside(valid, r, c, ny, nx):
    return 0 <= r < ny and 0 <= c < nx and valid[r, c]


@numba.njit(cache=True)
def convexity_floor(h, h_new, valid, r, c, dx, dy):
    """Lowest elevation (m) the cell (r, c) may be un-deposited to by 000 Eq. 17.

    m is the upwind gradient of h(t) normalised by its L1 norm; f is the elevation one cell
    up along m (weights |m_x|, |m_y|) and f² the same two cells up, both read on the
    elevations at t − Δt already computed (cells above are done first). The bound
    h(t − Δt) ≥ 2f − f² forbids a profile that steepens downhill, i.e. a vertical wall at the
    foot of un-eroded cliffs. Returns −inf when the cells needed are missing (edge, nodata) or
    no neighbour is higher.
    """
    ny, nx = h.shape
    gx, sx = _uphill_axis(h, valid, r, c, 0, 1, ny, nx)
    gy, sy = _uphill_axis(h, valid, r, c, 1, 0, ny, nx)
    gx /= dx
    gy /= dy
    total = gx + gy
    if total <= 0.0:
        return -np.inf
    wx, wy = gx / total, gy / total
    # cells one and two steps up: (r, c+sx), (r+sy, c), (r, c+2sx), (r+sy, c+sx), (r+2sy, c)
    need_x, need_y = wx > 0.0, wy > 0.0
    if need_x and not (_inside(valid, r, c + sx, ny, nx) and _inside(valid, r, c + 2 * sx, ny, nx)):
        return -np.inf
    if need_y and not (_inside(valid, r + sy, c, ny, nx) and _inside(valid, r + 2 * sy, c, ny, nx)):
        return -np.inf
    if need_x and need_y and not _inside(valid, r + sy, c + sx, ny, nx):
        return -np.inf
    f = 0.0
    f2 = 0.0
    if need_x:
        f += wx * h_new[r, c + sx]
        f2 += wx * wx * h_new[r, c + 2 * sx]
    if need_y:
        f += wy * h_new[r + sy, c]
        f2 += wy * wy * h_new[r + 2 * sy, c]
    if need_x and need_y:
        f2 += 2.0 * wx * wy * h_new[r + sy, c + sx]
    return 2.0 * f - f2


@numba.njit(cache=True)
def _uphill_neighbour_eroding(h, valid, eroding, r, c):
    """Whether one of the higher axis neighbours of (r, c) is un-eroded in this step (the
    interface between unerosion and un-deposition, where 000 Eq. 17 applies)."""
    ny, nx = h.shape
    for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        rr, cc = r + dr, c + dc
        if _inside(valid, rr, cc, ny, nx) and h[rr, cc] > h[r, c] and eroding[rr * nx + cc]:
            return True
    return False


@numba.njit(cache=True, inline="always")
def _cell_change(h, h_new, valid, eroding, i, r, c, arriving, slope, slope_down, k_th, tan_theta, dt,
                 dx, dy, alpha, max_rate, constraints):
    """(Δh (m), Qr (m³/y)) of cell i = (r, c) of ``thermal_sweep``, given the rock discharge
    Q̃r arriving from its donors (``arriving``, m³/y): erosion where |∇h| > tan θ (marked in
    ``eroding``), else deposition (dt > 0) or un-deposition under ``constraints`` (dt < 0), by
    the rules of ``thermal_sweep``'s docstring; Qr ≥ 0."""
    area = dx * dy
    step_len = min(dx, dy)
    excess = slope[i] - tan_theta
    if excess > 0.0:
        rate = _at(k_th, i) * excess
        change = -dt * rate
        leaving = arriving + rate * area
        eroding[i] = True
    elif dt > 0.0:
        change = min(dt * arriving / area, step_len * (tan_theta - slope[i]))
        leaving = arriving - change * area / dt
    else:
        span = abs(dt)
        depth = span * arriving / area
        if constraints & SLOPE_LIMIT:
            depth = min(depth, alpha * step_len * slope_down[i])
        if constraints & RATE_LIMIT:
            depth = min(depth, span * max_rate)
        if constraints & CONVEXITY and depth > 0.0 and _uphill_neighbour_eroding(
                h, valid, eroding, r, c):
            floor = convexity_floor(h, h_new, valid, r, c, dx, dy)
            depth = min(depth, max(0.0, h[r, c] - floor))
        change = -depth
        leaving = arriving - depth * area / span
    return change, max(leaving, 0.0)


@numba.njit(cache=True)
def thermal_sweep(zf, h, valid, outlets, order, dx, dy, single, slope, slope_down, k_th,
                  tan_theta, dt, alpha, max_rate, constraints):
    """One step of thermal erosion and deposition (000 Eq. 15) or of their reversal (000 §4.2)
    in a single pass over the cells, donors first, like 000 Algorithm 1.

    At each cell p, with every donor already done, Q̃r is the rock discharge arriving from
    the donors (m³/y, routed with the flow fractions of the routing surface, 000 Eq. 13):
      |∇h| > tan θ: erosion rate e = K_th·(|∇h| − tan θ) (m/y), Δh = −dt·e, Qr = Q̃r + e·A;
      otherwise, forward (dt > 0): deposition d = min(dt·Q̃r/A, Δx·(tan θ − |∇h|)) (m),
        Δh = +d, Qr = Q̃r − d·A/dt (000 Eq. 15);
      otherwise, backward (dt < 0): un-deposition d = |dt|·Q̃r/A (m), limited by the flags in
        ``constraints``: SLOPE_LIMIT d ≤ α·Δx·S_d (000 Eq. 16, S_d the downstream slope at
        t), RATE_LIMIT d ≤ |dt|·max_rate, CONVEXITY h − d ≥ 2f − f² at the foot of un-eroded
        cells (000 Eq. 17, ``convexity_floor``); Δh = −d, Qr = Q̃r − d·A/|dt|.
    Backward, the un-eroded volume is taken from the un-deposition cells below, and what they
    cannot give comes in through the outlets (negative outflux). Δx is min(dx, dy), the
    distance to the nearer axis neighbour. Outlets keep their elevation and let out what
    arrives.

    Args:
        zf, outlets, order, dx, dy, single: the routing (``unerode_cli.hydro``).
        h: float64[ny, nx] elevation at t (m); valid: bool[ny, nx] domain.
        slope: float64[ny*nx] |∇h| deciding erosion (downstream slope forward, limited or
            upwind slope backward); slope_down: float64[ny*nx] downstream slope S_d (000 Eq. 9).
        k_th: field K_th (m/y); tan_theta: tangent of the talus angle; dt: step (y).
        alpha: α of 000 Eq. 16; max_rate: maximal un-deposition rate (m/y).
        constraints: OR of SLOPE_LIMIT, CONVEXITY, RATE_LIMIT (backward only).

    Returns:
        (dh float64[ny*nx] (m), Qr float64[ny*nx] (m³/y), volume taken from the surface (m³),
         volume added to it (m³), rock discharge leaving through outlets (m³/y)).
    """
    ny, nx = zf.shape
    size = ny * nx
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    area = dx * dy
    frac = np.empty(8, dtype=np.float64)
    dh = np.zeros(size, dtype=np.float64)
    rock = np.zeros(size, dtype=np.float64)
    h_new = h.copy()
    eroding = np.zeros(size, dtype=np.bool_)
    removed = 0.0
    added = 0.0
    outflow_rate = 0.0
    for idx in range(order.size):
        i = order[idx]
        arriving = rock[i]
        if out[i]:
            outflow_rate += arriving
            continue
        r = i // nx
        c = i - r * nx
        change, leaving = _cell_change(h, h_new, valid, eroding, i, r, c, arriving, slope, slope_down, k_th,
                                       tan_theta, dt, dx, dy, alpha, max_rate, constraints)
        dh[i] = change
        h_new[r, c] = h[r, c] + change
        if change < 0.0:
            removed -= change * area
        else:
            added += change * area
        rock[i] = leaving
        interior = flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
        spread(rock, i, off, frac, leaving, interior)
    return dh, rock, removed, added, outflow_rate


@numba.njit(cache=True)
def max_speed(slope, free, k_th, tan_theta):
    """Largest K_th over the free cells steeper than the talus slope (m/y): the speed at
    which the erosion term of 000 Eq. 14 carries elevation changes upslope."""
    speed = 0.0
    for i in range(slope.size):
        if free[i] and slope[i] > tan_theta:
            speed = max(speed, _at(k_th, i))
    return speed


@numba.njit(cache=True)
def talus_automaton(h, valid, fixed, dx, dy, tan_theta, fraction):
    """One iteration of the thermal-erosion cellular automaton (Musgrave et al. 1989).

    Every free cell compares itself with its 8 neighbours: where the drop d_k to a neighbour
    exceeds the talus height T_k = tan θ·distance_k, the cell sends
    ``fraction``·max_k(d_k − T_k) metres of material to those neighbours, shared in
    proportion to their excess d_k − T_k (``fraction`` is a flat field, see ``_at``). All
    cells move material from the same h (Jacobi update), so the volume is conserved;
    material sent to a fixed cell leaves the domain there (fixed cells keep their
    elevation). ``fraction`` ≤ 0.5 keeps the exchange stable.

    Returns:
        (dh float64[ny, nx] (m), volume carried into fixed cells (m³)).
    """
    ny, nx = h.shape
    dh = np.zeros((ny, nx), dtype=np.float64)
    area = dx * dy
    drow = (-1, -1, -1, 0, 0, 1, 1, 1)
    dcol = (-1, 0, 1, -1, 1, -1, 0, 1)
    dist = np.empty(8, dtype=np.float64)
    for k in range(8):
        dist[k] = np.hypot(dcol[k] * dx, drow[k] * dy)
    excess = np.empty(8, dtype=np.float64)
    lost = 0.0
    for r in range(ny):
        for c in range(nx):
            if not valid[r, c] or fixed[r, c]:
                continue
            total, largest = 0.0, 0.0
            for k in range(8):
                rr, cc = r + drow[k], c + dcol[k]
                e = 0.0
                if 0 <= rr < ny and 0 <= cc < nx and valid[rr, cc]:
                    e = max(0.0, h[r, c] - h[rr, cc] - tan_theta * dist[k])
                excess[k] = e
                total += e
                largest = max(largest, e)
            if total <= 0.0:
                continue
            moved = _at(fraction, r * nx + c) * largest
            dh[r, c] -= moved
            for k in range(8):
                if excess[k] > 0.0:
                    share = moved * excess[k] / total
                    rr, cc = r + drow[k], c + dcol[k]
                    if fixed[rr, cc]:
                        lost += share * area
                    else:
                        dh[rr, cc] += share
    return dh, lost
