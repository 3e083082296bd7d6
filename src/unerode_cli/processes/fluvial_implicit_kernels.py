"""Numba kernels of the implicit forward fluvial step (Braun & Willett 2013; Yuan et al. 2019).

Fields (uplift, erodibility, K_d) are flat float64 arrays of size ny*nx, or of size 1 for a
value that is the same everywhere. Per-cell work arrays go by position in ``Routing.order``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.hydro.kernels import flow_fractions, inverse_distances, neighbour_offsets, spread

#: Bisection–Newton iterations of one cell's equation for n ≠ 1 (each at least halves the
#: bracket, so 200 reach the last bit of any float64 bracket).
CELL_ITERATIONS = 200


@numba.njit(cache=True, inline="always")
def _at(field, i):
    """Value of a scalar-or-raster field at flat index ``i``."""
    return field[0] if field.size == 1 else field[i]


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


@numba.njit(cache=True)
def implicit_sweep_into(h0, zf, outlets, order, dx, dy, single, q, gradient, k, n, m, k_d, uplift, dt,
                        qs_in, rtol, atol, max_iter, hn, qs, dep, coef, code):
    """One implicit forward step of 000 Eq. 3 (dt > 0).

    Stream power, implicit in the new elevations (Braun & Willett 2013): in a pass over the
    cells, receivers first, each cell's end-of-step elevation solves ``solve_cell`` with its
    receivers' end-of-step elevations, so any dt is stable. Deposition, the (K_d/Q)·Q̃s term,
    is iterated as in Yuan et al. (2019, §3.2): given the deposition rates D, the receivers-first
    pass gives the elevations; a donors-first pass then carries the sediment flux down
    (Q̃s arriving, Qs = Q̃s + (U − Δh/dt)·A leaving, exactly what the cell lost) and sets the new
    D = Q̃s·min(K_d/Q, 1/A) (000 Eq. 8, capped as the explicit step is); the passes repeat
    until D·dt changes by at most max(``atol``, ``rtol``·max|Δh|) (m) on every cell, or
    ``max_iter`` passes. Where the largest change has not halved in three passes, the rates are
    under-relaxed (D ← D + ω·(D_new − D), ω halved each time, down to 1/64).

    The sediment fluxes of the last pass follow from the elevations, so the mass budget holds
    to rounding whatever the iteration count; a leaving flux that would be negative (more
    deposited than arrived, only before convergence) is set to 0 and its volume returned.

    Args:
        h0: float64[ny*nx] elevation at the start (m).
        zf, outlets, order, dx, dy, single: the routing of ``h0`` (``unerode_cli.hydro``); the
            receivers and their weights are those of ``zf``, kept through the step.
        q: float64[ny*nx] discharge Q (m³/y).
        gradient: float64[ny*nx] |∇h| of ``h0`` (000 Eq. 9) to which each cell's weighted
            receiver slope is scaled at the start of the step, or float64[0] for none (D8).
        k: field K; n, m: exponents; k_d: field K_d (m/y); uplift: field U (m/y); dt: step (y).
        qs_in: float64[ny*nx] sediment flux entering each cell from outside the map (m³/y).
        rtol, atol: the iteration ends when no D·dt changed by more than max(atol, rtol times
            the largest |Δh| of the pass) (m).
        max_iter: most passes.
        hn: float64[ny*nx] set to the elevation at the end of the step (outlets: h0).
        qs: float64[ny*nx] set to the sediment flux Qs leaving each cell (m³/y; outlets: what
            leaves the map there).
        dep: float64[ny*nx] deposition rates D (m/y): on entry the first guess (e.g. the
            previous step's, or 0), on return those of the last pass.
        coef: float64[order.size] work array.
        code: int8[order.size] work array with D8 (each cell's receiver as a neighbour number,
            found once), int8[0] with MFD.

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
    depositing = coefficients_into(h0, z, out, order, ny, nx, off, inv_dist, single, q, gradient, k, n,
                                   m, k_d, dt, coef, code)
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
        receivers_pass(h0, z, out, order, ny, nx, off, inv_dist, single, n, uplift, dt, dep, coef, code, hn)
        change, largest, clipped, eroded, deposited = sediment_pass(
            h0, z, out, order, ny, nx, off, inv_dist, single, q, n, k_d, uplift, dt, qs_in, depositing,
            relax, dx * dy, dep, coef, code, hn, qs)
        tol = max(atol, rtol * largest)
        ratio = change / tol
        if change <= tol:
            break
        previous, stalled, relax = _relaxation(change, previous, stalled, relax)
    outflow = 0.0
    for p in range(order.size):
        i = order[p]
        if out[i]:
            outflow += qs[i]
    return passes, ratio, clipped, eroded, deposited, outflow


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
def _receivers_of(z, hn, i, p, ny, nx, off, inv_dist, single, code, frac, hr, a):
    """Fill ``hr`` and ``a`` with the receivers' elevations in ``hn`` and weights w_k / L_k
    (1/m) of cell ``i`` (position ``p`` in the order), ``frac`` with its flow fractions (MFD;
    D8 reads its receiver off ``code``); returns (count, interior)."""
    if single:
        best = code[p]
        if best < 0:
            return 0, False
        hr[0] = hn[i + off[best]]
        a[0] = inv_dist[best]
        return 1, False
    interior = flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
    count = 0
    for kk in range(8):
        if frac[kk] > 0.0:
            hr[count] = hn[i + off[kk]]
            a[count] = frac[kk] * inv_dist[kk]
            count += 1
    return count, interior


@numba.njit(cache=True)
def coefficients_into(h0, z, out, order, ny, nx, off, inv_dist, single, q, gradient, k, n, m, k_d, dt,
                      coef, code):
    """coef[p] = K·Q^m·dt of cell ``order[p]`` (times c^n, c = |∇h| / weighted receiver slope at
    the start, where ``gradient`` is given), 0 under a lake of the routing surface; with D8,
    code[p] = the neighbour number of its receiver (-1: none). Returns whether any K_d > 0."""
    frac = np.empty(8, dtype=np.float64)
    depositing = False
    scaled = gradient.size > 0
    for p in range(order.size):
        i = order[p]
        water = q[i]
        c = _at(k, i) * math.exp2(m * math.log2(water)) * dt if water > 0.0 else 0.0
        if z[i] > h0[i]:
            # under a lake of the routing surface (or raised across a flat): the water stands,
            # the sediment settles, nothing is incised
            c = 0.0
        if scaled and c > 0.0 and not out[i]:
            flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
            weighted = 0.0
            for kk in range(8):
                if frac[kk] > 0.0:
                    weighted += frac[kk] * inv_dist[kk] * max(h0[i] - h0[i + off[kk]], 0.0)
            if weighted > 0.0:
                ratio = gradient[i] / weighted
                c *= ratio if n == 1.0 else ratio**n
        coef[p] = c
        if single:
            code[p] = -1
            if not out[i]:
                flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
                for kk in range(8):
                    if frac[kk] > 0.0:
                        code[p] = kk
        depositing = depositing or _at(k_d, i) > 0.0
    return depositing


@numba.njit(cache=True)
def receivers_pass(h0, z, out, order, ny, nx, off, inv_dist, single, n, uplift, dt, dep, coef, code, hn):
    """Receivers first: each cell's end-of-step elevation from its receivers' (``solve_cell``)
    with the deposition rates ``dep``; outlets keep ``h0``."""
    frac = np.empty(8, dtype=np.float64)
    hr = np.empty(8, dtype=np.float64)
    a = np.empty(8, dtype=np.float64)
    for p in range(order.size - 1, -1, -1):
        i = order[p]
        if out[i]:
            hn[i] = h0[i]
            continue
        count, _ = _receivers_of(z, hn, i, p, ny, nx, off, inv_dist, single, code, frac, hr, a)
        hn[i] = solve_cell(h0[i] + dt * (_at(uplift, i) + dep[i]), hr, a, count, coef[p], n)


@numba.njit(cache=True)
def sediment_pass(h0, z, out, order, ny, nx, off, inv_dist, single, q, n, k_d, uplift, dt, qs_in,
                  depositing, relax, area, dep, coef, code, hn, qs):
    """Donors first: the sediment arriving at each cell sets its deposition rate (relaxed by
    ``relax``), the cell is solved again with it (from its receivers' current elevations), and
    what it lost, Qs = Q̃s + (U − Δh/dt)·A, goes on to its receivers. Returns (largest change
    of D·dt (m), largest |Δh| (m), volume rate set to 0 on negative fluxes, erosion and
    deposition rates (m³/y))."""
    frac = np.empty(8, dtype=np.float64)
    hr = np.empty(8, dtype=np.float64)
    a = np.empty(8, dtype=np.float64)
    inv_area = 1.0 / area
    change = 0.0
    clipped = 0.0
    largest = 0.0
    eroded = 0.0
    deposited = 0.0
    for i in range(qs.size):
        qs[i] = qs_in[i]
    for p in range(order.size):
        i = order[p]
        arriving = qs[i]
        if out[i]:
            continue
        count, interior = _receivers_of(z, hn, i, p, ny, nx, off, inv_dist, single, code, frac, hr, a)
        if depositing:
            # the deposition of the sediment arriving now, and the cell solved again with it:
            # sediment news travel down in this pass as base-level news travel up in the other
            # (a symmetric Gauss–Seidel sweep)
            water = q[i]
            kd = _at(k_d, i)
            if water > 0.0:
                trapping = min(kd / water, inv_area)
            else:
                trapping = inv_area if kd > 0.0 else 0.0
            fresh = arriving * trapping
            change = max(change, abs(fresh - dep[i]) * dt)
            dep[i] += relax * (fresh - dep[i])
            hn[i] = solve_cell(h0[i] + dt * (_at(uplift, i) + dep[i]), hr, a, count, coef[p], n)
        lost = _at(uplift, i) - (hn[i] - h0[i]) / dt
        largest = max(largest, abs(hn[i] - h0[i]))
        eroded += max(lost, 0.0) * area
        deposited += max(-lost, 0.0) * area
        leaving = arriving + lost * area
        if leaving < 0.0:
            clipped -= leaving
            leaving = 0.0
        qs[i] = leaving
        if single:
            if count > 0:
                qs[i + off[code[p]]] += leaving
        else:
            spread(qs, i, off, frac, leaving, interior)
    return change, largest, clipped, eroded, deposited


@numba.njit(cache=True)
def d8_sweep_into(h0, zf, outlets, order, dx, dy, q, k, n, m, k_d, uplift, dt, qs_in, rtol, atol,
                  max_iter, hn, qs, dep, work, position):
    """``implicit_sweep_into`` with one receiver per cell (D8), on arrays laid out in the
    routing's order: each pass then reads its cells one after the other, and only the
    receiver's elevation and sediment flux at another place, where elevation order would jump
    across the whole map for every array. Same arguments and results as
    ``implicit_sweep_into`` (for D8, without ``gradient``), with ``work`` float64[6, order.size]
    and ``position`` (an integer array of ny*nx, the dtype of ``order``) as scratch."""
    ny, nx = zf.shape
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    size = order.size
    area = dx * dy
    h0p, hnp, depp, qsp, coefp, trap = work[0], work[1], work[2], work[3], work[4], work[5]
    receiver = np.empty(size, dtype=order.dtype)   # position of the receiver; -1 none, -2 outlet
    depositing = _d8_layout(h0, z, out, order, ny, nx, off, inv_dist, q, k, n, m, k_d, dt, dep, area,
                            position, receiver, h0p, hnp, depp, coefp, trap)
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
        _d8_receivers_pass(order, receiver, uplift, dt, h0p, hnp, depp, coefp, n)
        change, largest, clipped, eroded, deposited = _d8_sediment_pass(
            order, receiver, uplift, dt, qs_in, depositing, relax, area, h0p, hnp, depp, coefp, trap,
            qsp, n)
        tol = max(atol, rtol * largest)
        ratio = change / tol
        if change <= tol:
            break
        previous, stalled, relax = _relaxation(change, previous, stalled, relax)
    outflow = 0.0
    for p in range(size):
        i = order[p]
        hn[i] = hnp[p]
        qs[i] = qsp[p]
        dep[i] = depp[p]
        if receiver[p] == -2:
            outflow += qsp[p]
    return passes, ratio, clipped, eroded, deposited, outflow


@numba.njit(cache=True)
def _d8_receivers_pass(order, receiver, uplift, dt, h0p, hnp, depp, coefp, n):
    """Receivers first, on arrays by position in ``order`` (see ``d8_sweep_into``)."""
    for p in range(order.size - 1, -1, -1):
        r = receiver[p]
        if r == -2:
            continue
        base = h0p[p] + dt * (_at(uplift, order[p]) + depp[p])
        hnp[p] = base if r < 0 else _d8_solve(base, hnp[r], coefp[p], n)


@numba.njit(cache=True)
def _d8_sediment_pass(order, receiver, uplift, dt, qs_in, depositing, relax, area, h0p, hnp, depp, coefp,
                      trap, qsp, n):
    """Donors first, on arrays by position in ``order``: ``sediment_pass`` for D8."""
    change = 0.0
    clipped = 0.0
    largest = 0.0
    eroded = 0.0
    deposited = 0.0
    for p in range(order.size):
        qsp[p] = qs_in[order[p]] if qs_in.size > 1 else 0.0
    for p in range(order.size):
        r = receiver[p]
        if r == -2:
            continue
        arriving = qsp[p]
        u = _at(uplift, order[p])
        if depositing:
            fresh = arriving * trap[p]
            change = max(change, abs(fresh - depp[p]) * dt)
            depp[p] += relax * (fresh - depp[p])
            base = h0p[p] + dt * (u + depp[p])
            hnp[p] = base if r < 0 else _d8_solve(base, hnp[r], coefp[p], n)
        step = hnp[p] - h0p[p]
        lost = u - step / dt
        largest = max(largest, abs(step))
        eroded += max(lost, 0.0) * area
        deposited += max(-lost, 0.0) * area
        leaving = arriving + lost * area
        if leaving < 0.0:
            clipped -= leaving
            leaving = 0.0
        qsp[p] = leaving
        if r >= 0:
            qsp[r] += leaving
    return change, largest, clipped, eroded, deposited


@numba.njit(cache=True, inline="always")
def _d8_solve(base, receiver, coef, n):
    """``solve_cell`` for one receiver with weight folded into ``coef`` (K·Q^m·dt / L^n)."""
    if base <= receiver or coef <= 0.0:
        return base
    if n == 1.0:
        return (base + coef * receiver) / (1.0 + coef)
    hr = np.empty(1)
    a = np.ones(1)
    hr[0] = receiver
    return solve_cell(base, hr, a, 1, coef, n)


@numba.njit(cache=True)
def _d8_layout(h0, z, out, order, ny, nx, off, inv_dist, q, k, n, m, k_d, dt, dep, area, position,
               receiver, h0p, hnp, depp, coefp, trap):
    """The D8 step's arrays by position in ``order``: start elevations, deposition rates (from
    ``dep``), K·Q^m·dt / L^n (0 under a lake of the routing surface), the trapping
    min(K_d/Q, 1/A), and each cell's receiver position (-1 none, -2 outlet). Returns whether
    any K_d > 0."""
    frac = np.empty(8, dtype=np.float64)
    for p in range(order.size):
        position[order[p]] = p
    depositing = False
    inv_area = 1.0 / area
    for p in range(order.size):
        i = order[p]
        h0p[p] = h0[i]
        hnp[p] = h0[i]
        depp[p] = dep[i]
        water = q[i]
        kd = _at(k_d, i)
        depositing = depositing or kd > 0.0
        if water > 0.0:
            trap[p] = min(kd / water, inv_area)
        else:
            trap[p] = inv_area if kd > 0.0 else 0.0
        if out[i]:
            receiver[p] = -2
            coefp[p] = 0.0
            continue
        receiver[p] = -1
        coefp[p] = 0.0
        flow_fractions(z, i, ny, nx, off, inv_dist, True, frac)
        for kk in range(8):
            if frac[kk] > 0.0:
                receiver[p] = position[i + off[kk]]
                if water > 0.0 and not z[i] > h0[i]:
                    c = _at(k, i) * math.exp2(m * math.log2(water)) * dt
                    coefp[p] = c * (inv_dist[kk] if n == 1.0 else inv_dist[kk] ** n)
    return depositing
