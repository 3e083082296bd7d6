"""Numba kernels of flow routing on an 8-neighbour grid.

Arrays are flattened row-major (row 0 = north); the flat index of cell (row, col) is
``row * nx + col``. The 8 neighbours of a cell are numbered 0..7 in row-major order of their
offsets ``(-1,-1), (-1,0), (-1,1), (0,-1), (0,1), (1,-1), (1,0), (1,1)``, so the neighbour
``k`` of a cell sees that cell as its neighbour ``7 - k``.

Flow is stored as ``weights: float64[ny*nx, 8]``: the fraction of a cell's flow that goes to
each neighbour (0 where the neighbour is not a receiver). Receivers are exactly the neighbours
with a positive weight; the weights of a cell that has receivers sum to 1.
"""

from __future__ import annotations

import numba
import numpy as np

DROW = np.array([-1, -1, -1, 0, 0, 1, 1, 1], dtype=np.int64)
DCOL = np.array([-1, 0, 1, -1, 1, -1, 0, 1], dtype=np.int64)


@numba.njit(cache=True, inline="always")
def _heap_push(keys, vals, size, key, val):
    """Push (key, val) on the binary min-heap held in keys[:size], vals[:size]; new size."""
    pos = size
    while pos > 0:
        parent = (pos - 1) >> 1
        if keys[parent] <= key:
            break
        keys[pos] = keys[parent]
        vals[pos] = vals[parent]
        pos = parent
    keys[pos] = key
    vals[pos] = val
    return size + 1


@numba.njit(cache=True, inline="always")
def _heap_pop(keys, vals, size):
    """Remove the root of the min-heap held in keys[:size]; returns (its value, new size)."""
    top = vals[0]
    size -= 1
    key = keys[size]
    val = vals[size]
    pos = 0
    while True:
        child = 2 * pos + 1
        if child >= size:
            break
        if child + 1 < size and keys[child + 1] < keys[child]:
            child += 1
        if keys[child] >= key:
            break
        keys[pos] = keys[child]
        vals[pos] = vals[child]
        pos = child
    keys[pos] = key
    vals[pos] = val
    return top, size


@numba.njit(cache=True)
def priority_flood_epsilon(z, valid, outlets):
    """Priority-flood+ε (Barnes, Lehman & Mulla 2014, Algorithm 3) on a routing copy of ``z``.

    Seeded from the outlets, every other valid cell reached is raised to at least the next
    representable float above the cell that floods it, so that it has a strictly lower valid
    neighbour. Nodata cells are never entered. ``z`` is not modified.

    Args:
        z: float64[ny, nx] elevation (m).
        valid: bool[ny, nx] domain mask.
        outlets: bool[ny, nx] valid cells that drain out of the domain.

    Returns:
        (filled float64[ny, nx], number of valid cells reached, outlets included).
    """
    ny, nx = z.shape
    n = ny * nx
    zf = z.ravel().copy()
    ok = valid.ravel()
    out = outlets.ravel()
    closed = np.zeros(n, dtype=np.bool_)
    keys = np.empty(n, dtype=np.float64)
    vals = np.empty(n, dtype=np.int64)
    size = 0
    pit = np.empty(n, dtype=np.int64)
    pit_head = 0
    pit_tail = 0
    reached = 0
    for i in range(n):
        if out[i] and ok[i]:
            closed[i] = True
            size = _heap_push(keys, vals, size, zf[i], i)
            reached += 1
    while size > 0 or pit_head < pit_tail:
        if pit_head < pit_tail:
            c = pit[pit_head]
            pit_head += 1
        else:
            c, size = _heap_pop(keys, vals, size)
        r = c // nx
        col = c - r * nx
        zc = zf[c]
        for k in range(8):
            rr = r + DROW[k]
            cc = col + DCOL[k]
            if rr < 0 or rr >= ny or cc < 0 or cc >= nx:
                continue
            j = rr * nx + cc
            if closed[j] or not ok[j]:
                continue
            closed[j] = True
            reached += 1
            if zf[j] <= zc:
                zf[j] = np.nextafter(zc, np.inf)
                pit[pit_tail] = j
                pit_tail += 1
            else:
                size = _heap_push(keys, vals, size, zf[j], j)
    return zf.reshape(ny, nx), reached


@numba.njit(cache=True, parallel=True)
def flow_weights(zf, valid, outlets, dx, dy, single):
    """Receivers and flow fractions of every cell from a depression-free surface.

    Multiple flow direction (000 Eq. 6): each strictly lower valid neighbour receives a
    fraction proportional to the slope (Δh / distance) towards it. With ``single`` (D8), the
    steepest neighbour receives everything; ties go to the first neighbour in row-major order.
    Distances are ``dx`` east-west, ``dy`` north-south and ``sqrt(dx² + dy²)`` on diagonals (m).
    Outlets and nodata cells have no receivers.

    Returns:
        weights float64[ny*nx, 8].
    """
    ny, nx = zf.shape
    diag = np.sqrt(dx * dx + dy * dy)
    dist = np.array([diag, dy, diag, dx, dx, diag, dy, diag])
    w = np.zeros((ny * nx, 8), dtype=np.float64)
    for r in numba.prange(ny):
        for col in range(nx):
            if not valid[r, col] or outlets[r, col]:
                continue
            i = r * nx + col
            h = zf[r, col]
            total = 0.0
            best = -1
            best_slope = 0.0
            for k in range(8):
                rr = r + DROW[k]
                cc = col + DCOL[k]
                if rr < 0 or rr >= ny or cc < 0 or cc >= nx or not valid[rr, cc]:
                    continue
                drop = h - zf[rr, cc]
                if drop > 0.0:
                    s = drop / dist[k]
                    if single:
                        if s > best_slope:
                            best_slope = s
                            best = k
                    else:
                        w[i, k] = s
                        total += s
            if single:
                if best >= 0:
                    w[i, best] = 1.0
            elif total > 0.0:
                for k in range(8):
                    w[i, k] /= total
    return w


@numba.njit(cache=True)
def topological_order(weights, valid, outlets):
    """Valid cells ordered so that every cell comes before all of its receivers.

    Kahn's algorithm run upstream from the outlets: a cell is taken once all its receivers
    have been taken; the result is then reversed (donors first, "descending" order of
    000 Algorithm 1). Cells that cannot reach an outlet are left out.

    Returns:
        int64[k] flat indices, k ≤ number of valid cells.
    """
    ny, nx = valid.shape
    n = ny * nx
    ok = valid.ravel()
    out = outlets.ravel()
    pending = np.zeros(n, dtype=np.int8)
    for i in range(n):
        cnt = 0
        for k in range(8):
            if weights[i, k] > 0.0:
                cnt += 1
        pending[i] = cnt
    stack = np.empty(n, dtype=np.int64)
    top = 0
    for i in range(n):
        if ok[i] and out[i]:
            stack[top] = i
            top += 1
    ascending = np.empty(n, dtype=np.int64)
    count = 0
    while top > 0:
        top -= 1
        c = stack[top]
        ascending[count] = c
        count += 1
        r = c // nx
        col = c - r * nx
        for k in range(8):
            rr = r + DROW[k]
            cc = col + DCOL[k]
            if rr < 0 or rr >= ny or cc < 0 or cc >= nx:
                continue
            j = rr * nx + cc
            if weights[j, 7 - k] > 0.0:
                pending[j] -= 1
                if pending[j] == 0:
                    stack[top] = j
                    top += 1
    return ascending[:count][::-1].copy()


@numba.njit(cache=True)
def accumulate_flow(order, weights, nx, source):
    """Upstream integral of ``source`` (000 Eq. 5): acc = source + Σ_donors α · acc(donor).

    Args:
        order: int64 flat indices, donors before receivers (cells not listed stay 0).
        weights: float64[n, 8] flow fractions.
        nx: number of columns.
        source: float64[n] per-cell contribution (e.g. p · cell area, m³/y), or float64[1]
            for the same contribution everywhere.

    Returns:
        float64[n] accumulated values.
    """
    acc = np.zeros(weights.shape[0], dtype=np.float64)
    uniform = source.size == 1
    for idx in range(order.size):
        i = order[idx]
        a = acc[i] + (source[0] if uniform else source[i])
        acc[i] = a
        for k in range(8):
            wk = weights[i, k]
            if wk > 0.0:
                acc[i + DROW[k] * nx + DCOL[k]] += wk * a
    return acc


@numba.njit(cache=True, parallel=True)
def steepest_receiver(weights, nx):
    """Flat index of the receiver with the largest flow fraction (the steepest one, first in
    row-major order on ties), -1 for cells without receivers."""
    n = weights.shape[0]
    rcv = np.full(n, -1, dtype=np.int64)
    for i in numba.prange(n):
        best = 0.0
        for k in range(8):
            if weights[i, k] > best:
                best = weights[i, k]
                rcv[i] = i + DROW[k] * nx + DCOL[k]
    return rcv
