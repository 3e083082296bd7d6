"""Numba kernels of flow routing on an 8-neighbour grid.

Arrays are flattened row-major (row 0 = north); the flat index of cell (row, col) is
``row * nx + col``. The 8 neighbours of a cell are numbered 0..7 in row-major order of their
offsets ``(-1,-1), (-1,0), (-1,1), (0,-1), (0,1), (1,-1), (1,0), (1,1)``.

Receivers are not stored: they are read off the routing surface ``zf`` (the elevation after
priority-flood+ε, +inf on nodata) and the outlet mask. The receivers of a valid non-outlet cell
are its strictly lower neighbours (all of them for multiple flow directions, the steepest one
for D8); outlets and nodata cells have none. A nodata neighbour (+inf) is never lower, so
nodata cells never receive flow.
"""

from __future__ import annotations

import numba
import numpy as np

DROW = np.array([-1, -1, -1, 0, 0, 1, 1, 1], dtype=np.int64)
DCOL = np.array([-1, 0, 1, -1, 1, -1, 0, 1], dtype=np.int64)
# Smallest rise (m) given to a filled cell above the cell that floods it. One ulp alone would
# make slopes near 0 m denormal, or underflow to 0 once divided by a distance.
FILL_EPSILON = 1e-9


@numba.njit(cache=True)
def fingerprint_words(words):
    """A 64-bit fingerprint of the 1-d uint64 array ``words`` (e.g. float64 bits): each word
    is mixed in by h ← rotl(h ⊕ w·k₁, 31)·k₂ (odd k₂), a bijection of h for a given word, so
    two arrays of the same size that differ in a single word always differ in fingerprint;
    others collide with a chance of about 2⁻⁶⁴."""
    k1 = np.uint64(0x9E3779B185EBCA87)
    k2 = np.uint64(0xC2B2AE3D27D4EB4F)
    h = np.uint64(0x27D4EB2F165667C5)
    for i in range(words.size):
        h ^= words[i] * k1
        h = ((h << np.uint64(31)) | (h >> np.uint64(33))) * k2
    return h ^ np.uint64(words.size)


@numba.njit(cache=True)
def inverse_distances(dx, dy):
    """float64[8] inverse of the distance (1/m) to each neighbour: dx east-west, dy
    north-south, sqrt(dx² + dy²) on diagonals."""
    d = 1.0 / np.sqrt(dx * dx + dy * dy)
    return np.array([d, 1.0 / dy, d, 1.0 / dx, 1.0 / dx, d, 1.0 / dy, d])


@numba.njit(cache=True, inline="always")
def _heap_push(heap, size, key, val):
    """Push (key, val) on the 4-ary min-heap held in heap[:size] as rows (key, val); returns
    the new size. Values are flat cell indices stored exactly as float64."""
    pos = size
    while pos > 0:
        parent = (pos - 1) >> 2
        if heap[parent, 0] <= key:
            break
        heap[pos, 0] = heap[parent, 0]
        heap[pos, 1] = heap[parent, 1]
        pos = parent
    heap[pos, 0] = key
    heap[pos, 1] = val
    return size + 1


@numba.njit(cache=True, inline="always")
def _heap_pop(heap, size):
    """Remove the root of the 4-ary min-heap held in heap[:size]; returns (its value as a
    flat index, the new size)."""
    top = np.int64(heap[0, 1])
    size -= 1
    key = heap[size, 0]
    val = heap[size, 1]
    pos = 0
    while True:
        first = 4 * pos + 1
        if first >= size:
            break
        best = first
        best_key = heap[first, 0]
        for child in range(first + 1, min(first + 4, size)):
            if heap[child, 0] < best_key:
                best_key = heap[child, 0]
                best = child
        if best_key >= key:
            break
        heap[pos, 0] = best_key
        heap[pos, 1] = heap[best, 1]
        pos = best
    heap[pos, 0] = key
    heap[pos, 1] = val
    return top, size


# Mean number of cells per bucket of the priority queue of ``priority_flood_epsilon``.
CELLS_PER_BUCKET = 8


@numba.njit(cache=True, inline="always")
def _bucket(key, zmin, inv_width, last):
    """Bucket (0..last) of a priority-queue key (m): floor((key − zmin) / width), clamped.
    Non-decreasing in ``key``, which is all the queue needs."""
    return min(max(np.int64((key - zmin) * inv_width), 0), last)


@numba.njit(cache=True)
def priority_flood_epsilon(z, valid, outlets):
    """Priority-flood+ε (Barnes, Lehman & Mulla 2014, Algorithm 3) on a routing copy of ``z``.

    Seeded from the outlets, every other valid cell reached is raised to at least ε above the
    cell that floods it, ε = max(FILL_EPSILON, one ulp), so that it has a strictly lower valid
    neighbour. Cells are taken from the priority queue and from the pit queue (FIFO) whichever
    is lower, the priority queue on ties, so cells leave in non-decreasing order of the
    routing surface: that sequence is an order in which every cell comes after all of its
    strictly lower neighbours. ``z`` is not modified; nodata cells are never entered.

    The priority queue is a bucket queue (Dial 1969) in front of a 4-ary min-heap. Its keys
    are elevations, and a key pushed is never below the last one taken (it is above the cell
    being processed), so the elevation range is cut into about n / CELLS_PER_BUCKET buckets
    of equal width: a key in a later bucket than the current one is appended to that bucket's
    list (O(1)), the others go on the heap, which only holds the current bucket and stays
    small; when the heap runs empty, the next non-empty bucket is poured into it. Cells leave
    in the same order as from a single heap (up to the order of equal keys).

    Args:
        z: float64[ny, nx] elevation (m).
        valid: bool[ny, nx] domain mask.
        outlets: bool[ny, nx] valid cells that drain out of the domain.

    Returns:
        (zf float64[ny, nx] routing surface, +inf on nodata;
         int64[k] flat indices of the k valid cells reached, outlets included, in reverse
         order of leaving the queues: every cell before its strictly lower neighbours).
    """
    n = z.size
    zf = np.empty(n, dtype=np.float64)
    descending = np.empty(n, dtype=np.int64)
    count = flood_into(
        z,
        valid,
        outlets,
        zf,
        descending,
        np.empty(n, dtype=np.bool_),
        np.empty(bucket_count(n), dtype=np.int64),
        np.empty(n, dtype=np.int64),
        np.empty((n, 2), dtype=np.float64),
        np.empty(n, dtype=np.int64),
    )
    return zf.reshape(z.shape), descending[n - count :]


@numba.njit(cache=True)
def bucket_count(n):
    """Number of buckets of the priority queue of ``flood_into`` for ``n`` cells."""
    return max(n // CELLS_PER_BUCKET, 1) + 1


@numba.njit(cache=True, inline="always")
def _flood_start(zin, ok, out, zf, closed, first, following):
    """The start of ``flood_into``: ``zf`` set to the elevations ``zin`` (m; +inf on nodata),
    ``closed`` to the outlets and the nodata cells, and the bucket lists (``first``,
    ``following``) to the outlets, the elevation range of the valid cells cut into
    ``first.size`` buckets. Returns (zmin (m), 1 / bucket width (1/m; 0: a single bucket),
    index of the last bucket)."""
    n = zin.size
    zmin = np.inf
    zmax = -np.inf
    for i in range(n):
        if ok[i]:
            zf[i] = zin[i]
            closed[i] = out[i]
            zmin = min(zmin, zin[i])
            zmax = max(zmax, zin[i])
        else:
            zf[i] = np.inf
            closed[i] = True
    last = first.size - 1
    span = zmax - zmin
    inv_width = last / span if span > 0.0 else 0.0
    if not inv_width < np.inf:  # unbounded range or overflow: a single bucket
        inv_width = 0.0
    first[:] = -1
    for i in range(n):
        if ok[i] and out[i]:
            b = _bucket(zin[i], zmin, inv_width, last)
            following[i] = first[b]
            first[b] = i
    return zmin, inv_width, last


@numba.njit(cache=True)
def flood_into(z, valid, outlets, zf, descending, closed, first, following, heap, pit):
    """``priority_flood_epsilon`` into arrays given by the caller, which may reuse them.

    Args:
        z, valid, outlets: as for ``priority_flood_epsilon``.
        zf: float64[ny*nx] set to the routing surface (m).
        descending: int[ny*nx] whose last ``count`` entries are set to the order.
        closed: bool[ny*nx], first: int[bucket_count(ny*nx)], following: int[ny*nx],
            heap: float64[ny*nx, 2], pit: int[ny*nx]: scratch, any content; the integer
            arrays (``descending`` too) hold flat cell indices and may be int32 when
            ny*nx < 2^31.

    Returns:
        count, the number of valid cells reached.
    """
    ny, nx = z.shape
    n = ny * nx
    zmin, inv_width, last = _flood_start(z.ravel(), valid.ravel(), outlets.ravel(), zf, closed, first,
                                         following)
    current = -1  # buckets up to this one are on the heap
    size = 0
    off = neighbour_offsets(nx)
    inv_nx = 1.0 / nx
    pit_head = 0
    pit_tail = 0
    count = 0
    while True:
        while size == 0 and current < last:
            current += 1
            j = first[current]
            while j >= 0:
                size = _heap_push(heap, size, zf[j], j)
                j = following[j]
        if pit_head < pit_tail and (size == 0 or zf[pit[pit_head]] < heap[0, 0]):
            c = pit[pit_head]
            pit_head += 1
            if pit_head == pit_tail:  # empty: start again at the front (touches fewer pages)
                pit_head = 0
                pit_tail = 0
        elif size > 0:
            c, size = _heap_pop(heap, size)
        else:
            break
        count += 1
        descending[n - count] = c
        r = row_of(c, inv_nx)
        col = c - r * nx
        interior = 0 < r < ny - 1 and 0 < col < nx - 1
        zc = zf[c]
        lifted = zc + FILL_EPSILON  # = max(zc + ε, next float above zc)
        if lifted <= zc:
            lifted = np.nextafter(zc, np.inf)
        for k in range(8):
            if not interior:
                rr = r + DROW[k]
                cc = col + DCOL[k]
                if rr < 0 or rr >= ny or cc < 0 or cc >= nx:
                    continue
            j = c + off[k]
            if closed[j]:
                continue
            closed[j] = True
            zj = zf[j]
            if zj <= zc:
                zf[j] = lifted
                pit[pit_tail] = j
                pit_tail += 1
            else:
                b = _bucket(zj, zmin, inv_width, last)
                if b <= current:
                    size = _heap_push(heap, size, zj, j)
                else:
                    following[j] = first[b]
                    first[b] = j
    return count


@numba.njit(cache=True, inline="always")
def flow_fractions(zf, i, ny, nx, off, inv_dist, single, frac):
    """Fill ``frac[0..7]`` with the fraction of the flow of cell ``i`` sent to each neighbour;
    returns whether the cell lies off the grid border (then every neighbour exists).

    Multiple flow directions (000 Eq. 6): every strictly lower neighbour gets a fraction
    proportional to the slope (Δh / distance, m/m) towards it. ``single`` (D8): the steepest
    neighbour gets everything; ties go to the first neighbour in row-major order. ``frac`` is
    all 0 when no neighbour is lower. The caller excludes outlets, which have no receivers.

    Args:
        zf: float64[ny*nx] routing surface (+inf on nodata), ``off``: int64[8] flat offsets
        of the neighbours, ``inv_dist``: float64[8] inverse distances (1/m).
    """
    r = i // nx
    col = i - r * nx
    interior = 0 < r < ny - 1 and 0 < col < nx - 1
    h = zf[i]
    total = 0.0
    for k in range(8):
        s = 0.0
        if interior or (0 <= r + DROW[k] < ny and 0 <= col + DCOL[k] < nx):
            s = max(h - zf[i + off[k]], 0.0) * inv_dist[k]
        frac[k] = s
        total += s
    if single:
        best = 0
        best_slope = frac[0]
        for k in range(1, 8):
            steeper = frac[k] > best_slope
            best = k if steeper else best
            best_slope = frac[k] if steeper else best_slope
        for k in range(8):
            frac[k] = 0.0
        if best_slope > 0.0:
            frac[best] = 1.0
    else:
        scale = 1.0 / total if total > 0.0 else 0.0
        for k in range(8):
            frac[k] *= scale
    return interior


@numba.njit(cache=True)
def spread(acc, i, off, frac, value, interior):
    """Route ``value`` from cell ``i`` to its receivers: ``acc[i + off[k]] += frac[k] * value``."""
    if interior:
        for k in range(8):
            acc[i + off[k]] += frac[k] * value
    else:
        for k in range(8):
            if frac[k] > 0.0:
                acc[i + off[k]] += frac[k] * value


@numba.njit(cache=True)
def neighbour_offsets(nx):
    """int64[8] flat-index offsets of the 8 neighbours on a grid of ``nx`` columns."""
    return DROW * nx + DCOL


@numba.njit(cache=True, inline="always")
def row_of(i, inv_nx):
    """Row of flat index ``i`` on a grid whose row length has the reciprocal ``inv_nx``:
    floor((i + 0.5) / nx), exact while ny·nx < 2^40 (the rounding error of the product is far
    below the 0.5/nx margin to the nearest integer); cheaper than an integer division."""
    return np.int64((i + 0.5) * inv_nx)


@numba.njit(cache=True, inline="always")
def slope_to(z, h, j, w):
    """Slope (m/m) from a cell of routing elevation ``h`` down to cell ``j``, 0 if ``j`` is
    not lower; ``w`` is the inverse distance (1/m). As in ``flow_fractions``."""
    return max(h - z[j], 0.0) * w


@numba.njit(cache=True, inline="always")
def steepest_of(z, i, h, off, inv_dist):
    """Neighbour number (0..7) of the steepest lower neighbour of interior cell ``i``, -1 if
    none is lower; ties go to the first in row-major order. Same slopes and comparisons as
    ``flow_fractions`` with ``single`` (D8), without branches on the data."""
    best = -1
    best_slope = 0.0
    for k in range(8):
        s = slope_to(z, h, i + off[k], inv_dist[k])
        steeper = s > best_slope
        best = k if steeper else best
        best_slope = s if steeper else best_slope
    return best


@numba.njit(cache=True, inline="always")
def mfd_shares(z, i, h, off, inv_dist):
    """The 8 fractions of ``flow_fractions`` (000 Eq. 6) for an interior cell ``i`` of routing
    elevation ``h``, as a tuple, computed with the same operations in the same order, so the
    shares are bit-identical; all 0 when no neighbour is lower."""
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
    return (s0 * scale, s1 * scale, s2 * scale, s3 * scale,
            s4 * scale, s5 * scale, s6 * scale, s7 * scale)


@numba.njit(cache=True, inline="always")
def spread_mfd(acc, z, i, h, off, inv_dist, value):
    """Multiple flow directions at an interior cell ``i`` in one pass, for a 1-d ``acc``:
    ``acc[i + off[k]] += frac[k] * value`` with the fractions of ``mfd_shares``."""
    shares = mfd_shares(z, i, h, off, inv_dist)
    for k in range(8):
        acc[i + off[k]] += shares[k] * value


@numba.njit(cache=True, inline="always")
def spread_mfd_pair(acc, value, acc2, value2, z, i, h, off, inv_dist):
    """``spread_mfd`` of two quantities with the same shares (e.g. water and sediment), the
    two updates of each receiver side by side."""
    shares = mfd_shares(z, i, h, off, inv_dist)
    for k in range(8):
        j = i + off[k]
        acc[j] += shares[k] * value
        acc2[j] += shares[k] * value2


@numba.njit(cache=True)
def accumulate_flow(zf, outlets, order, dx, dy, single, source):
    """Upstream integral of ``source`` (000 Eq. 5): acc = source + Σ_donors α · acc(donor).

    One pass over ``order`` (donors first, 000 Algorithm 1). Interior cells compute their
    fractions and spread in one go (``steepest_of``, ``spread_mfd``), border cells through
    ``flow_fractions`` and ``spread``; both give the same shares.

    Args:
        zf: float64[ny, nx] routing surface (+inf on nodata).
        outlets: bool[ny, nx] sinks (they keep what they receive).
        order: flat indices (int32 or int64) of the valid cells, every cell before its receivers.
        dx, dy: cell sizes (m).
        single: D8 instead of multiple flow directions.
        source: float64[ny*nx] per-cell contribution (e.g. p · cell area, m³/y), or
            float64[1] for the same contribution everywhere.

    Returns:
        float64[ny*nx] accumulated values, 0 on cells not in ``order``.
    """
    acc = np.zeros(zf.size, dtype=np.float64)
    accumulate_into(zf, outlets, order, dx, dy, single, source, acc)
    return acc


@numba.njit(cache=True)
def accumulate_into(zf, outlets, order, dx, dy, single, source, acc):
    """``accumulate_flow`` into ``acc`` (float64[ny*nx], all 0 on entry)."""
    ny, nx = zf.shape
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    inv_nx = 1.0 / nx
    frac = np.empty(8, dtype=np.float64)
    uniform = source.size == 1
    for idx in range(order.size):
        i = order[idx]
        a = acc[i] + (source[0] if uniform else source[i])
        acc[i] = a
        if out[i]:
            continue
        r = row_of(i, inv_nx)
        col = i - r * nx
        if 0 < r < ny - 1 and 0 < col < nx - 1:
            if single:
                k = steepest_of(z, i, z[i], off, inv_dist)
                if k >= 0:
                    acc[i + off[k]] += a
            else:
                spread_mfd(acc, z, i, z[i], off, inv_dist, a)
        else:
            interior = flow_fractions(z, i, ny, nx, off, inv_dist, single, frac)
            spread(acc, i, off, frac, a, interior)


@numba.njit(cache=True)
def fraction_field(zf, outlets, dx, dy, single):
    """float64[ny*nx, 8] flow fractions of every cell to its 8 neighbours (0 for outlets and
    nodata)."""
    ny, nx = zf.shape
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    res = np.zeros((ny * nx, 8), dtype=np.float64)
    for i in range(ny * nx):
        if not out[i] and z[i] < np.inf:
            flow_fractions(z, i, ny, nx, off, inv_dist, single, res[i])
    return res


@numba.njit(cache=True)
def steepest_receiver(zf, outlets, dx, dy):
    """int64[ny*nx] flat index of the steepest lower neighbour (first in row-major order on
    ties), -1 for outlets, nodata cells and cells without a lower neighbour."""
    ny, nx = zf.shape
    z = zf.ravel()
    out = outlets.ravel()
    off = neighbour_offsets(nx)
    inv_dist = inverse_distances(dx, dy)
    frac = np.empty(8, dtype=np.float64)
    rcv = np.full(ny * nx, -1, dtype=np.int64)
    for i in range(ny * nx):
        if not out[i] and z[i] < np.inf:
            flow_fractions(z, i, ny, nx, off, inv_dist, True, frac)
            k = np.argmax(frac)
            if frac[k] > 0.0:
                rcv[i] = i + off[k]
    return rcv
