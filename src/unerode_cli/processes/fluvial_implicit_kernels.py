"""Numba kernels of the implicit forward fluvial step (Braun & Willett 2013; Yuan et al. 2019).

Fields (uplift, erodibility, K_d) are flat float64 arrays of size ny*nx, or of size 1 for a
value that is the same everywhere. Per-cell work arrays go by position in ``Routing.order``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.hydro.kernels import flow_fractions, inverse_distances, neighbour_offsets
from unerode_cli.processes.fluvial_kernels import DOWNSTREAM, _at, cell_slope

#: Bisection–Newton iterations of one cell's equation for n ≠ 1 (each at least halves the
#: bracket, so 200 reach the last bit of any float64 bracket).
CELL_ITERATIONS = 200


@numba.njit(cache=True, inline="always")
def _incision(h, hr, a, count, n):
    """S(h)^n with S(h) = Σ_k a_k·max(0, h − hr_k) (m/m): the receiver-weighted slope of a cell
    at elevation ``h`` above its ``count`` receivers at elevations ``hr`` (a_k = w_k / L_k,
    1/m), and its derivative d(S^n)/dh."""
    s = 0.0
    ds = 0.0
    for k in range(count):
        if h > hr[k]:
            s += a[k] * (h - hr[k])
            ds += a[k]
    if s <= 0.0:
        return 0.0, 0.0
    if n == 1.0:
        return s, ds
    power = s**n
    return power, n * power / s * ds


@numba.njit(cache=True)
def solve_cell(base, hr, a, count, coef, n):
    """Elevation h (m) at the end of the step of a cell that solves

        h = base − coef·S(h)^n,   S(h) = Σ_k a_k·max(0, h − hr_k)            (000 Eq. 1, implicit)

    where ``base`` = h(t) + dt·(U + D) (m), ``coef`` = K·Q^m·dt and ``hr`` the receivers'
    elevations at the end of the step (Braun & Willett 2013, Eq. 20–23, with several receivers
    weighted by a_k = w_k / L_k). The left side minus the right is increasing in h, so the root
    is unique and lies in [min hr, base]; with n = 1 it is found exactly on the set of receivers
    below it, else by Newton steps kept inside a shrinking bracket (bisection where a step
    leaves it). A cell at or below all its receivers is not incised (h = base)."""
    if count == 1 and n == 1.0:
        # one receiver (D8): Braun & Willett's (h + F·h_r) / (1 + F), F = coef·a
        if coef <= 0.0 or base <= hr[0]:
            return base
        f = coef * a[0]
        return (base + f * hr[0]) / (1.0 + f)
    low = math.inf
    for k in range(count):
        low = min(low, hr[k])
    if count == 0 or coef <= 0.0 or base <= low:
        return base
    if n == 1.0:
        # the receivers below the root are those below the candidate; drop the highest above it
        h = base
        for _ in range(count + 1):
            weight = 0.0
            pulled = 0.0
            for k in range(count):
                if hr[k] < h:
                    weight += a[k]
                    pulled += a[k] * hr[k]
            candidate = (base + coef * pulled) / (1.0 + coef * weight)
            settled = True
            for k in range(count):
                if hr[k] < h and hr[k] >= candidate:
                    settled = False
            h = candidate
            if settled:
                return h
        return h
    lo = low
    hi = base
    h = base
    for _ in range(CELL_ITERATIONS):
        power, slope = _incision(h, hr, a, count, n)
        f = h - base + coef * power
        if f > 0.0:
            hi = h
        else:
            lo = h
        derivative = 1.0 + coef * slope
        step = h - f / derivative
        h = step if lo < step < hi else 0.5 * (lo + hi)
        if hi - lo <= 1e-13 * max(abs(hi), 1.0) or f == 0.0:
            break
    return h


@numba.njit(cache=True, inline="always")
def _relaxation(change, previous, stalled, relax):
    """(previous, stalled, relax) after a pass whose largest change of D·dt is ``change``:
    where the change has not halved in three passes the rates overshoot or cycle (deposition
    raising a cell above its receivers, whose incision then sends the sediment on), and their
    update is relaxed by half again, down to 1/64."""
    if change < 0.5 * previous:
        return change, 0, relax
    stalled += 1
    if stalled == 3:
        return previous, 0, max(0.5 * relax, 1.0 / 64.0)
    return previous, stalled, relax


@numba.njit(cache=True, inline="always")
def _leaving(arriving, u, start, end, dt, area):
    """(Qs leaving a cell, its Δh, its net loss (U − Δh/dt)·A): what arrived plus what the cell
    lost over the step (m³/y, m, m³/y); Qs < 0 only before convergence (the caller clips it)."""
    step = end - start
    lost = (u - step / dt) * area
    return arriving + lost, step, lost


@numba.njit(cache=True, inline="always")
def _gather_cell(p, i, h0, dep, water, k_d, inv_area, h0p, hnp, depp, trap):
    """Position ``p`` of the in-order arrays from cell ``i``: start elevation, first deposition
    rate, and the trapping min(K_d/Q, 1/A) (000 Eq. 8, capped at what arrives); returns K_d > 0."""
    h0p[p] = h0[i]
    hnp[p] = h0[i]
    depp[p] = dep[i]
    kd = _at(k_d, i)
    if water > 0.0:
        trap[p] = min(kd / water, inv_area)
    else:
        trap[p] = inv_area if kd > 0.0 else 0.0
    return kd > 0.0


@numba.njit(cache=True)
def implicit_sweep_into(h0, valid, zf, outlets, order, dx, dy, single, q, k, n, m, k_d, uplift, dt,
                        qs_in, rtol, atol, max_iter, hn, qs, dep, work, work32, position):
    """One implicit forward step of 000 Eq. 3 (dt > 0).

    Stream power, implicit in the new elevations (Braun & Willett 2013): in a pass over the
    cells, receivers first, each cell's end-of-step elevation solves ``solve_cell`` with its
    receivers' end-of-step elevations, so any dt is stable. Deposition, the (K_d/Q)·Q̃s term,
    is iterated as in Yuan et al. (2019, §3.2): given the deposition rates D, the receivers-first
    pass gives the elevations; a donors-first pass then carries the sediment flux down
    (Q̃s arriving, Qs = Q̃s + (U − Δh/dt)·A leaving, exactly what the cell lost) and sets the new
    D = Q̃s·min(K_d/Q, 1/A) (000 Eq. 8, capped as the explicit step is); the passes repeat
    until D·dt changes by at most max(``atol``, ``rtol``·max|Δh|) (m) on every cell, or
    ``max_iter`` passes; where the largest change has not halved in three passes, the rates
    are under-relaxed (D ← D + ω·(D_new − D), ω halved each time, down to 1/64).

    The arrays are laid out in the routing's order (each pass reads its cells in sequence),
    each cell's receivers (positions, fractions, neighbour numbers) listed once. The sediment
    fluxes of the last pass follow from the elevations, so the mass budget holds to rounding
    whatever the iteration count; a leaving flux that would be negative (more deposited than
    arrived, only before convergence) is set to 0 and its volume returned.

    Args:
        h0: float64[ny*nx] elevation at the start (m).
        zf, outlets, order, dx, dy, single: the routing of ``h0`` (``unerode_cli.hydro``); the
            receivers and their weights are those of ``zf``, kept through the step.
        q: float[ny*nx] discharge Q (m³/y).
        valid: bool[ny, nx] the domain, for |∇h| of ``h0`` (000 Eq. 9), to which each cell's
            weighted receiver slope is scaled at the start of the step with MFD.
        k: field K; n, m: exponents; k_d: field K_d (m/y); uplift: field U (m/y); dt: step (y).
        qs_in: float64[ny*nx] sediment flux entering each cell from outside the map (m³/y),
            or float64[1] for none; rtol, atol, max_iter: as above.
        hn: float64[ny*nx] set to the elevation at the end of the step (outlets: h0).
        qs: float64[ny*nx] set to the sediment flux Qs leaving each cell (m³/y; outlets: what
            leaves the map there).
        dep: float64[ny*nx] deposition rates D (m/y): on entry the first guess (e.g. the
            previous step's, or 0), on return those of the last pass.
        work, work32, position: scratch: float64[4, order.size], float32[2, order.size] (K·Q^m·dt
            and the trapping) and of ny*nx (``order``'s dtype).

    Returns:
        (passes, largest change of D·dt in the last pass ÷ the tolerance it had to meet (≤ 1:
        converged; 0 without deposition), volume rate set to 0 on negative fluxes, rates of
        erosion and deposition Σ max(0, ±(U − Δh/dt))·A over the free cells and of outflux
        Σ Qs over the outlets (m³/y)).
    """
    ny, nx = zf.shape
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    size = order.size
    area = dx * dy
    (h0p, hnp, depp, qsp), (coefp, trap) = work, work32
    start = _starts(z, out, order, ny, nx, off, inv_dist, single, position)
    rcv = np.empty(start[size], dtype=order.dtype)
    share = np.empty(start[size], dtype=np.float32)
    code = np.empty(start[size], dtype=np.int8)
    depositing = _layout(h0, valid, z, out, order, ny, nx, off, inv_dist, single, q, k, n, m, k_d, dt,
                         dep, dx, dy, position, start, rcv, share, code, h0p, hnp, depp, coefp, trap)
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
        _receivers_pass(order, out, start, rcv, share, code, inv_dist, uplift, dt, h0p, hnp, depp,
                            coefp, n)
        change, largest, clipped, eroded, deposited = _sediment_pass(
            order, out, start, rcv, share, code, inv_dist, uplift, dt, qs_in, depositing, relax, area,
            h0p, hnp, depp, coefp, trap, qsp, n)
        tol = max(atol, rtol * largest)
        ratio = change / tol
        if change <= tol:
            break
        previous, stalled, relax = _relaxation(change, previous, stalled, relax)
    return passes, ratio, clipped, eroded, deposited, _scatter(order, out, hnp, qsp, depp, hn, qs, dep)


@numba.njit(cache=True)
def _starts(z, out, order, ny, nx, off, inv_dist, single, position):
    """position[order[p]] = p, and where each position's receivers start in the lists
    (int64[order.size + 1])."""
    size = order.size
    for p in range(size):
        position[order[p]] = p
    start = np.empty(size + 1, dtype=np.int64)
    frac = np.empty(8, dtype=np.float64)
    start[0] = 0
    for p in range(size):
        i = order[p]
        count = 0
        if single:
            # the routing gives every cell but the outlets a strictly lower neighbour
            count = 0 if out[i] else 1
        elif not out[i]:
            flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
            for kk in range(8):
                count += frac[kk] > 0.0
        start[p + 1] = start[p] + count
    return start


@numba.njit(cache=True)
def _scatter(order, out, hnp, qsp, depp, hn, qs, dep):
    """Elevations, fluxes and deposition rates back from positions to cells; returns the
    outflux (m³/y), Σ Qs over the outlets."""
    outflow = 0.0
    for p in range(order.size):
        i = order[p]
        hn[i] = hnp[p]
        qs[i] = qsp[p]
        dep[i] = depp[p]
        if out[i]:
            outflow += qsp[p]
    return outflow


@numba.njit(cache=True, inline="always")
def _gather(p, start, rcv, share, code, inv_dist, hnp, hr, a):
    """The receivers of position ``p``: elevations from ``hnp`` into ``hr``, weights w_k / L_k
    into ``a``; returns their count."""
    count = 0
    for j in range(start[p], start[p + 1]):
        hr[count] = hnp[rcv[j]]
        a[count] = share[j] * inv_dist[code[j]]
        count += 1
    return count


@numba.njit(cache=True)
def _receivers_pass(order, out, start, rcv, share, code, inv_dist, uplift, dt, h0p, hnp, depp, coefp,
                        n):
    """Receivers first, on arrays by position in ``order``."""
    hr = np.empty(8, dtype=np.float64)
    a = np.empty(8, dtype=np.float64)
    for p in range(order.size - 1, -1, -1):
        if out[order[p]]:
            continue
        count = _gather(p, start, rcv, share, code, inv_dist, hnp, hr, a)
        hnp[p] = solve_cell(h0p[p] + dt * (_at(uplift, order[p]) + depp[p]), hr, a, count, coefp[p], n)


@numba.njit(cache=True)
def _sediment_pass(order, out, start, rcv, share, code, inv_dist, uplift, dt, qs_in, depositing, relax,
                       area, h0p, hnp, depp, coefp, trap, qsp, n):
    """Donors first, on arrays by position in ``order``: the sediment arriving at each cell
    sets its deposition rate (relaxed by ``relax``), the cell is solved again with it (from its
    receivers' current elevations: sediment news travel down in this pass as base-level news
    travel up in the other, a symmetric Gauss–Seidel sweep), and what it lost,
    Qs = Q̃s + (U − Δh/dt)·A, goes on to its receivers. Returns (largest change of D·dt (m),
    largest |Δh| (m), volume rate set to 0 on negative fluxes, erosion and deposition rates
    (m³/y))."""
    hr = np.empty(8, dtype=np.float64)
    a = np.empty(8, dtype=np.float64)
    change = 0.0
    clipped = 0.0
    largest = 0.0
    eroded = 0.0
    deposited = 0.0
    for p in range(order.size):
        qsp[p] = qs_in[order[p]] if qs_in.size > 1 else 0.0
    for p in range(order.size):
        if out[order[p]]:
            continue
        arriving = qsp[p]
        u = _at(uplift, order[p])
        if depositing:
            fresh = arriving * trap[p]
            change = max(change, abs(fresh - depp[p]) * dt)
            depp[p] += relax * (fresh - depp[p])
            count = _gather(p, start, rcv, share, code, inv_dist, hnp, hr, a)
            hnp[p] = solve_cell(h0p[p] + dt * (u + depp[p]), hr, a, count, coefp[p], n)
        leaving, step, lost = _leaving(arriving, u, h0p[p], hnp[p], dt, area)
        largest = max(largest, abs(step))
        eroded += max(lost, 0.0)
        deposited += max(-lost, 0.0)
        clipped += max(-leaving, 0.0)
        leaving = max(leaving, 0.0)
        qsp[p] = leaving
        # float32 fractions: the last receiver takes what the others leave, so that the flux
        # is passed on whole
        rest = leaving
        last = start[p + 1] - 1
        for j in range(start[p], last):
            part = share[j] * leaving
            qsp[rcv[j]] += part
            rest -= part
        if last >= start[p]:
            qsp[rcv[last]] += rest
    return change, largest, clipped, eroded, deposited


@numba.njit(cache=True)
def _layout(h0, valid, z, out, order, ny, nx, off, inv_dist, single, q, k, n, m, k_d, dt, dep, dx, dy,
            position, start, rcv, share, code, h0p, hnp, depp, coefp, trap):
    """The step's arrays by position in ``order`` (start elevations, first deposition rates,
    trapping), each cell's receivers listed from ``start[p]`` to ``start[p + 1]`` (positions,
    flow fractions, neighbour numbers; one with D8), and K·Q^m·dt, with MFD scaled to 000 Eq. 9's
    gradient (c = |∇h| / the weighted receiver slope, K·Q^m·dt·c^n); 0 under a lake of the
    routing surface (or raised across a flat), where the water stands, the sediment settles and
    nothing is incised. Returns whether any K_d > 0."""
    frac = np.empty(8, dtype=np.float64)
    depositing = False
    inv_area = 1.0 / (dx * dy)
    grid_h0 = h0.reshape(ny, nx)
    for p in range(order.size):
        i = order[p]
        water = q[i]
        depositing = _gather_cell(p, i, h0, dep, water, k_d, inv_area, h0p, hnp, depp, trap) or depositing
        coefp[p] = 0.0
        if out[i]:
            continue
        flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
        j = start[p]
        weighted = 0.0
        for kk in range(8):
            if frac[kk] > 0.0:
                rcv[j] = position[i + off[kk]]
                share[j] = frac[kk]
                code[j] = kk
                weighted += frac[kk] * inv_dist[kk] * max(h0[i] - h0[i + off[kk]], 0.0)
                j += 1
        if water > 0.0 and not z[i] > h0[i]:
            c = _at(k, i) * math.exp2(m * math.log2(water)) * dt
            if weighted > 0.0 and not single:
                r = i // nx
                ratio = cell_slope(grid_h0, valid, r, i - r * nx, dx, dy, DOWNSTREAM) / weighted
                c *= ratio if n == 1.0 else ratio**n
            coefp[p] = c
    return depositing
