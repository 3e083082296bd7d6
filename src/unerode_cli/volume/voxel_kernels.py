"""Numba kernels of voxel grids (layout and units in ``voxels``): the top surface of each
column, and the changes a point source of matter (x, y, z, Q, R) makes to density voxels (003
Eq. 13) and to binary voxels (003 Eq. 14), applied in order. Nothing here knows about particles.

Point coordinates are grid coordinates: x = column·dx, y = row·dy (m, y south, voxel centres at
integer column and row) and the elevation z (m), voxel k's centre at z0 + (k + ½)·dz.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def cell_frac(s, n):
    """Lower index and fraction of a coordinate ``s`` on n points at the integers (cell centres
    or nodes), clamped to them."""
    s = min(max(s, 0.0), n - 1.0)
    i = min(int(s), n - 2) if n > 1 else 0
    return i, s - i


@numba.njit(cache=True)
def bilinear(a, col, row):
    """Bilinear a[row, column] at coordinates (col, row) of its points (e.g. (x/dx, y/dy)),
    clamped at the border."""
    ny, nx = a.shape
    c, fx = cell_frac(col, nx)
    r, fy = cell_frac(row, ny)
    c1, r1 = min(c + 1, nx - 1), min(r + 1, ny - 1)
    return (a[r, c] * (1.0 - fx) + a[r, c1] * fx) * (1.0 - fy) + (a[r1, c] * (1.0 - fx) + a[r1, c1] * fx) * fy


@numba.njit(cache=True)
def column_top(values, r, c, z0, dz):
    """Elevation (m) of the highest ground surface of column (r, c) of a density (or of binary
    voxels given as ±1): the f = 0 crossing above the highest voxel with f > 0, by linear
    interpolation between voxel centres (the top face of a full voxel under an empty one; air
    above the grid); z0, the bottom of the grid, for a column without ground."""
    nz = values.shape[2]
    k = nz - 1
    while k >= 0 and values[r, c, k] <= 0:
        k -= 1
    if k < 0:
        return z0
    fk = float(values[r, c, k])
    above = float(values[r, c, k + 1]) if k + 1 < nz else -1.0
    return z0 + (k + 0.5) * dz + dz * fk / (fk - above)


@numba.njit(cache=True, parallel=True)
def top_surface(values, z0, dz):
    """``column_top`` of every column: float64[rows, columns] (m)."""
    ny, nx, _ = values.shape
    out = np.empty((ny, nx))
    for r in numba.prange(ny):
        for c in range(nx):
            out[r, c] = column_top(values, r, c, z0, dz)
    return out


@numba.njit(cache=True)
def _sphere_box(x, y, z, radius, dx, dy, dz, z0, shape):
    """Index bounds (r0, r1, c0, c1, k0, k1), inclusive, of the voxels whose centre may lie
    within ``radius`` of (x, y, z) (grid coordinates, m)."""
    ny, nx, nz = shape
    r0 = max(0, int(math.ceil((y - radius) / dy)))
    r1 = min(ny - 1, int(math.floor((y + radius) / dy)))
    c0 = max(0, int(math.ceil((x - radius) / dx)))
    c1 = min(nx - 1, int(math.floor((x + radius) / dx)))
    kz = (z - z0) / dz - 0.5
    k0 = max(0, int(math.ceil(kz - radius / dz)))
    k1 = min(nz - 1, int(math.floor(kz + radius / dz)))
    return r0, r1, c0, c1, k0, k1


@numba.njit(cache=True)
def sphere_buffers(radius, dx, dy, dz):
    """Buffers (voxel flat indices, weights) large enough for the sphere of ``radius`` (m)."""
    m = (int(2.0 * radius / dx) + 2) * (int(2.0 * radius / dy) + 2) * (int(2.0 * radius / dz) + 2)
    return np.empty(m, np.int64), np.empty(m)


@numba.njit(cache=True)
def _nearest(x, y, z, dx, dy, dz, z0, shape):
    """Flat index of the voxel nearest to (x, y, z) (grid coordinates, m), clamped to the grid."""
    ny, nx, nz = shape
    r = min(max(int(round(y / dy)), 0), ny - 1)
    c = min(max(int(round(x / dx)), 0), nx - 1)
    k = min(max(int(math.floor((z - z0) / dz)), 0), nz - 1)
    return (r * nx + c) * nz + k


@numba.njit(cache=True, inline="always")
def _recolour(material, flat, before, after, rules):
    """Material rules of a voxel whose density went from ``before`` to ``after`` (> 0: ground):
    one that becomes ground by deposition takes the deposit material (when ≥ 0); ground that
    loses matter and stays ground becomes what its material turns into when eroded."""
    if material.size == 0:
        return
    deposit_material, on_erosion, _ = rules
    if before <= 0.0 < after:
        if deposit_material >= 0:
            material.flat[flat] = deposit_material
    elif 0.0 < after < before:
        material.flat[flat] = on_erosion[material.flat[flat]]


@numba.njit(cache=True)
def _add_density(f, material, flat, df, rules):
    """Add ``df`` to voxel ``flat`` of the density f; what would take it above 1 goes on to the
    voxels above, what would take it below −1 to the voxels below (003 §4.4: "when f(p) > 1 we
    transport the density excess to the above voxel", and its mirror for erosion). Returns what
    leaves the column through its top (> 0) or bottom (< 0), in units of f."""
    nz = f.shape[2]
    k = flat % nz
    step = 1 if df > 0.0 else -1
    while df != 0.0 and 0 <= k < nz:
        before = f.flat[flat]
        after = before + df
        if after > 1.0:
            df = after - 1.0
            after = 1.0
        elif after < -1.0:
            df = after + 1.0
            after = -1.0
        else:
            df = 0.0
        f.flat[flat] = after
        _recolour(material, flat, before, after, rules)
        k += step
        flat += step
    return df


@numba.njit(cache=True, inline="always")
def _weight(d, radius, erode, material, flat, rules):
    """Share of a voxel at distance d (m) from an impact of radius R: 1 − d/R (003 Eq. 13),
    times its material's erodibility K_ε for erosion when the rules give erodibilities (a
    dissolving impact takes more of the softer voxels around it: 003 §5 Karst)."""
    w = 1.0 - d / radius
    erodibility = rules[2]
    if erode and erodibility.size > 0 and material.size > 0:
        w *= erodibility[material.flat[flat]]
    return w


@numba.njit(cache=True)
def _gather(values, binary, material, valid, dx, dy, dz, z0, x, y, z, q, radius, rules, index, weight):
    """The voxels an impact (x, y, z, Q, R) changes and their weights (``_weight``), into the
    buffers: those of valid columns whose centre lies within R of the impact and that can
    change that way — density voxels (``binary`` False, ``values`` f) below 1 for a deposit and
    above −1 for erosion, binary voxels (``values`` the solid mask) of air for a deposit and
    ground for erosion. Returns (count, Σ weights)."""
    erode = q < 0.0
    r0, r1, c0, c1, k0, k1 = _sphere_box(x, y, z, radius, dx, dy, dz, z0, values.shape)
    nx, nz = values.shape[1], values.shape[2]
    count = 0
    total = 0.0
    for r in range(r0, r1 + 1):
        ddy = r * dy - y
        for c in range(c0, c1 + 1):
            if not valid[r, c]:
                continue
            ddx = c * dx - x
            base = (r * nx + c) * nz
            for k in range(k0, k1 + 1):
                ddz = z0 + (k + 0.5) * dz - z
                d = math.sqrt(ddx * ddx + ddy * ddy + ddz * ddz)
                if d >= radius:
                    continue
                v = values.flat[base + k]
                if binary:
                    movable = v == erode
                else:
                    movable = v > -1.0 if erode else v < 1.0
                if movable:
                    w = _weight(d, radius, erode, material, base + k, rules)
                    if w > 0.0:
                        index[count] = base + k
                        weight[count] = w
                        total += w
                        count += 1
    return count, total


@numba.njit(cache=True)
def density_event(f, material, valid, dx, dy, dz, z0, x, y, z, q, radius, rules, index, weight):
    """Apply one change of matter Q (m³, > 0 deposits) at (x, y, z) with radius R to density
    voxels in place (003 Eq. 13): it goes to the voxels ``_gather`` finds, Δf = 2Q·w/(V·Σw)
    with V a voxel's volume, so that Σ (1 + f)/2·V changes by exactly Q (the matter of a voxel
    is (1 + f)/2 of it). When none is within R the voxel nearest the impact takes it all. What
    a voxel cannot hold goes up (deposits) or down (erosion) its column (``_add_density``).
    ``index``, ``weight``: buffers of ``sphere_buffers(R)``. Returns the matter (m³) that left
    the grid through the top (> 0) or bottom (< 0) of a column."""
    if q == 0.0:
        return 0.0
    volume = dx * dy * dz
    count, total = _gather(f, False, material, valid, dx, dy, dz, z0, x, y, z, q, radius, rules, index,
                           weight)
    if count == 0:
        index[0] = _nearest(x, y, z, dx, dy, dz, z0, f.shape)
        weight[0] = 1.0
        total = 1.0
        count = 1
    scale = 2.0 * q / (volume * total)
    left = 0.0
    for j in range(count):
        left += 0.5 * _add_density(f, material, index[j], scale * weight[j], rules) * volume
    return left


@numba.njit(cache=True)
def apply_density(f, material, valid, dx, dy, dz, z0, ex, ey, ez, eq, er, rules):
    """Apply point changes of matter (x, y, z, Q, R) to density voxels in place, in their order
    (``density_event``, 003 Eq. 13).

    Args:
        f: float64[rows, columns, layers] density, changed in place.
        material: int16 index per voxel (same shape) changed by the material rules, or an
            empty array (no materials).
        valid: bool[rows, columns], the columns that may change.
        dx, dy, dz: voxel sizes (m); z0: elevation of the grid's bottom (m).
        ex, ey, ez: grid coordinates of the changes (m); eq: Q (m³); er: R (m).
        rules: (deposit material (−1: keep), int16[n] the material each one becomes when
            eroded, float64[n] erodibility of each one weighting erosion (empty: uniform)).

    Returns:
        The volume of matter (m³) that left the grid through the tops (> 0) and bottoms (< 0)
        of its columns.
    """
    rmax = 0.0
    for i in range(er.size):
        rmax = max(rmax, er[i])
    index, weight = sphere_buffers(rmax, dx, dy, dz)
    left = 0.0
    for i in range(eq.size):
        left += density_event(f, material, valid, dx, dy, dz, z0, ex[i], ey[i], ez[i], eq[i], er[i], rules,
                              index, weight)
    return left


#: Counters of ``apply_binary`` (indices into its result).
EROSION_HITS, DEPOSITION_HITS, REMOVED, ADDED, TRANSFORMED, UNPLACED_HITS = 0, 1, 2, 3, 4, 5
N_COUNTERS = 6


@numba.njit(cache=True)
def _add_hits(solid, hits, material, flat, n, threshold, rules, counters):
    """Add ``n`` hits (> 0 erosion, < 0 deposition) to voxel ``flat`` and flip it (003 Eq. 14):
    ground with hits ≥ C turns to air, or into ``on_erosion`` of its material when that differs
    (003 §7); air with hits ≤ −C turns to ground, of ``deposit_material`` when ≥ 0. Each flip
    takes C hits off the voxel's count (``rules``: those of ``apply_density``). What is left on a
    flipped voxel goes on, as the excess of a density does (003 §4.4), to the next ground voxel
    below (erosion) or the next air voxel above (deposition) in its column; what goes past the
    grid's bottom or top is taken off the EROSION_HITS or DEPOSITION_HITS counter and added to
    UNPLACED_HITS. So ground holds hits in
    [0, C) and air in (−C, 0] once they are settled, and the hits kept in voxels always equal
    EROSION_HITS − DEPOSITION_HITS − C·(REMOVED + TRANSFORMED − ADDED) plus those they held before."""
    nz = solid.shape[2]
    k = flat % nz
    erode = n > 0
    has_material = material.size > 0
    deposit_material, on_erosion, _ = rules
    hits.flat[flat] += n
    while True:
        if erode:
            while solid.flat[flat] and hits.flat[flat] >= threshold:
                hits.flat[flat] -= threshold
                m = material.flat[flat] if has_material else 0
                if has_material and on_erosion[m] != m:
                    material.flat[flat] = on_erosion[m]
                    counters[TRANSFORMED] += 1
                else:
                    solid.flat[flat] = False
                    counters[REMOVED] += 1
            if solid.flat[flat] or hits.flat[flat] <= 0:
                return
        else:
            if not solid.flat[flat] and hits.flat[flat] <= -threshold:
                hits.flat[flat] += threshold
                solid.flat[flat] = True
                if has_material and deposit_material >= 0:
                    material.flat[flat] = deposit_material
                counters[ADDED] += 1
            if not solid.flat[flat] or hits.flat[flat] >= 0:
                return
        rest = hits.flat[flat]
        hits.flat[flat] = 0
        step = -1 if erode else 1
        k += step
        flat += step
        while 0 <= k < nz and solid.flat[flat] != erode:
            k += step
            flat += step
        if not 0 <= k < nz:
            counters[EROSION_HITS if erode else DEPOSITION_HITS] -= abs(rest)
            counters[UNPLACED_HITS] += abs(rest)
            return
        hits.flat[flat] += rest


@numba.njit(cache=True)
def binary_event(solid, hits, material, valid, dx, dy, dz, z0, x, y, z, q, radius, alpha, threshold, rules,
                 index, weight, counters):
    """Apply one change of matter Q (m³, < 0 erosion) at (x, y, z) with radius R to binary
    voxels in place (003 Eq. 14), adding to ``counters`` (``N_COUNTERS``).

    Q is shared as in ``density_event`` (``_gather``: the voxels within R it can flip, ground
    for erosion and air for a deposit); a voxel's share |ΔV| = |Q|·w/Σw becomes Δhits =
    ⌊α·|ΔV|/V⌋ hits (α hits per voxel volume of matter; positive for erosion, negative for
    deposition; 003 writes ⌊αΔf⌋) and ``_add_hits`` flips it at ±C (``threshold``). When no
    such voxel is within R, the voxel nearest the impact takes it all, or the first one of its
    column that can flip (downwards for erosion, upwards for a deposit)."""
    if q == 0.0:
        return
    erode = q < 0.0
    volume = dx * dy * dz
    nz = solid.shape[2]
    count, total = _gather(solid, True, material, valid, dx, dy, dz, z0, x, y, z, q, radius, rules, index,
                           weight)
    if count == 0:
        flat = _nearest(x, y, z, dx, dy, dz, z0, solid.shape)
        step = -1 if erode else 1
        k = flat % nz
        while 0 <= k < nz and solid.flat[flat] != erode:
            k += step
            flat += step
        if not 0 <= k < nz:
            counters[UNPLACED_HITS] += int(alpha * abs(q) / volume)
            return
        index[0] = flat
        weight[0] = 1.0
        total = 1.0
        count = 1
    for j in range(count):
        n = int(alpha * abs(q) * weight[j] / (total * volume))
        if n == 0:
            continue
        counters[EROSION_HITS if erode else DEPOSITION_HITS] += n
        _add_hits(solid, hits, material, index[j], n if erode else -n, threshold, rules, counters)


@numba.njit(cache=True)
def apply_binary(solid, hits, material, valid, dx, dy, dz, z0, ex, ey, ez, eq, er, alpha, threshold, rules):
    """Apply point changes of matter (x, y, z, Q, R) to binary voxels in place, in their order
    (``binary_event``, 003 Eq. 14); the arguments are those of ``apply_density``, with the
    solid mask, the hit counts, α (hits per voxel volume) and the threshold C (hits).

    Returns:
        int64[N_COUNTERS]: hits applied by erosion and by deposition (both ≥ 0) and kept in the
        grid, voxels removed, added and transformed, and the hits that found no voxel in their
        column or were carried past its bottom or top.
    """
    rmax = 0.0
    for i in range(er.size):
        rmax = max(rmax, er[i])
    index, weight = sphere_buffers(rmax, dx, dy, dz)
    counters = np.zeros(N_COUNTERS, np.int64)
    for i in range(eq.size):
        binary_event(solid, hits, material, valid, dx, dy, dz, z0, ex[i], ey[i], ez[i], eq[i], er[i], alpha,
                     threshold, rules, index, weight, counters)
    return counters
