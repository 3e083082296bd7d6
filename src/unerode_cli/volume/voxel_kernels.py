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


@numba.njit(cache=True, parallel=True)
def top_surface(values, z0, dz):
    """Elevation (m) of the highest ground surface of each column of a density (or of binary
    voxels given as ±1): the f = 0 crossing above the highest voxel with f > 0, by linear
    interpolation between voxel centres (the top face of a full voxel under an empty one; air
    above the grid). A column without ground gives z0, the bottom of the grid.
    Returns float64[rows, columns]."""
    ny, nx, nz = values.shape
    out = np.empty((ny, nx))
    for r in numba.prange(ny):
        for c in range(nx):
            k = nz - 1
            while k >= 0 and values[r, c, k] <= 0:
                k -= 1
            if k < 0:
                out[r, c] = z0
                continue
            fk = float(values[r, c, k])
            above = float(values[r, c, k + 1]) if k + 1 < nz else -1.0
            out[r, c] = z0 + (k + 0.5) * dz + dz * fk / (fk - above)
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


@numba.njit(cache=True)
def _recolour(material, flat, before, after, deposit_material, on_erosion):
    """Material rules of a voxel whose density went from ``before`` to ``after`` (> 0: ground):
    one that becomes ground by deposition takes ``deposit_material`` (when ≥ 0); ground that
    loses matter and stays ground becomes ``on_erosion`` of its material."""
    if material.size == 0:
        return
    if before <= 0.0 < after:
        if deposit_material >= 0:
            material.flat[flat] = deposit_material
    elif 0.0 < after < before:
        material.flat[flat] = on_erosion[material.flat[flat]]


@numba.njit(cache=True)
def _add_density(f, material, flat, df, deposit_material, on_erosion):
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
        _recolour(material, flat, before, after, deposit_material, on_erosion)
        k += step
        flat += step
    return df


@numba.njit(cache=True)
def apply_density(f, material, valid, dx, dy, dz, z0, ex, ey, ez, eq, er, deposit_material, on_erosion):
    """Apply point changes of matter (x, y, z, Q, R) to density voxels in place, in their order
    (003 Eq. 13).

    A change Q (m³, > 0 deposits) at c with radius R goes to the voxels of valid columns whose
    centre p lies within R of c and whose density can move that way (f < 1 for a deposit,
    f > −1 for erosion), in proportion to w = 1 − ‖p − c‖/R: Δf = 2Q·w/(V·Σw), V a voxel's
    volume, so that Σ (1 + f)/2·V changes by exactly Q (the matter of a voxel is (1 + f)/2 of
    it). When none is within R the voxel nearest c takes it all. What a voxel cannot hold goes
    up (deposits) or down (erosion) its column; what leaves the grid is returned.

    Args:
        f: float64[rows, columns, layers] density, changed in place.
        material: int16 index per voxel (same shape) changed by the rules of ``_recolour``,
            or an empty array (no materials).
        valid: bool[rows, columns], the columns that may change.
        dx, dy, dz: voxel sizes (m); z0: elevation of the grid's bottom (m).
        ex, ey, ez: grid coordinates of the changes (m); eq: Q (m³); er: R (m).
        deposit_material, on_erosion: the material rules (``_recolour``).

    Returns:
        The volume of matter (m³) that left the grid through the tops (> 0) and bottoms (< 0)
        of its columns.
    """
    volume = dx * dy * dz
    rmax = 0.0
    for i in range(er.size):
        rmax = max(rmax, er[i])
    index, weight = sphere_buffers(rmax, dx, dy, dz)
    nx, nz = f.shape[1], f.shape[2]
    left = 0.0
    for i in range(eq.size):
        q = eq[i]
        if q == 0.0:
            continue
        radius = er[i]
        r0, r1, c0, c1, k0, k1 = _sphere_box(ex[i], ey[i], ez[i], radius, dx, dy, dz, z0, f.shape)
        count = 0
        total = 0.0
        for r in range(r0, r1 + 1):
            ddy = r * dy - ey[i]
            for c in range(c0, c1 + 1):
                if not valid[r, c]:
                    continue
                ddx = c * dx - ex[i]
                base = (r * nx + c) * nz
                for k in range(k0, k1 + 1):
                    ddz = z0 + (k + 0.5) * dz - ez[i]
                    d = math.sqrt(ddx * ddx + ddy * ddy + ddz * ddz)
                    v = f.flat[base + k]
                    if d < radius and ((q > 0.0 and v < 1.0) or (q < 0.0 and v > -1.0)):
                        index[count] = base + k
                        weight[count] = 1.0 - d / radius
                        total += weight[count]
                        count += 1
        if count == 0:
            index[0] = _nearest(ex[i], ey[i], ez[i], dx, dy, dz, z0, f.shape)
            weight[0] = 1.0
            total = 1.0
            count = 1
        scale = 2.0 * q / (volume * total)
        for j in range(count):
            rest = _add_density(f, material, index[j], scale * weight[j], deposit_material, on_erosion)
            left += 0.5 * rest * volume
    return left


#: Counters of ``apply_binary`` (indices into its result).
EROSION_HITS, DEPOSITION_HITS, REMOVED, ADDED, TRANSFORMED, UNPLACED_HITS = 0, 1, 2, 3, 4, 5
N_COUNTERS = 6


@numba.njit(cache=True)
def _add_hits(solid, hits, material, flat, n, threshold, deposit_material, on_erosion, counters):
    """Add ``n`` hits (> 0 erosion, < 0 deposition) to voxel ``flat`` and flip it (003 Eq. 14):
    ground with hits ≥ C turns to air, or into ``on_erosion`` of its material when that differs
    (003 §7); air with hits ≤ −C turns to ground, of ``deposit_material`` when ≥ 0. Each flip
    takes C hits off the voxel's count."""
    hits.flat[flat] += n
    has_material = material.size > 0
    while solid.flat[flat] and hits.flat[flat] >= threshold:
        hits.flat[flat] -= threshold
        m = material.flat[flat] if has_material else 0
        if has_material and on_erosion[m] != m:
            material.flat[flat] = on_erosion[m]
            counters[TRANSFORMED] += 1
        else:
            solid.flat[flat] = False
            counters[REMOVED] += 1
    if not solid.flat[flat] and hits.flat[flat] <= -threshold:
        hits.flat[flat] += threshold
        solid.flat[flat] = True
        if has_material and deposit_material >= 0:
            material.flat[flat] = deposit_material
        counters[ADDED] += 1


@numba.njit(cache=True)
def apply_binary(solid, hits, material, valid, dx, dy, dz, z0, ex, ey, ez, eq, er, alpha, threshold,
                 deposit_material, on_erosion):
    """Apply point changes of matter (x, y, z, Q, R) to binary voxels in place, in their order
    (003 Eq. 14).

    Q (m³, < 0 erosion) is shared as in ``apply_density`` (Eq. 13 weights w = 1 − d/R) among
    the voxels within R that it can flip (ground for erosion, air for a deposit); a voxel's
    share |ΔV| = |Q|·w/Σw becomes Δhits = ⌊α·|ΔV|/V⌋ hits (α hits per voxel volume of matter;
    positive for erosion, negative for deposition; 003 writes ⌊αΔf⌋) and ``_add_hits`` flips
    it at ±C (``threshold``). When no such voxel is within R, the voxel nearest c takes it all,
    or the first one of its column that can flip (downwards for erosion, upwards for a deposit).

    Returns:
        int64[N_COUNTERS]: hits applied by erosion and by deposition (both ≥ 0), voxels removed,
        added and transformed, and the hits of changes that found no voxel in their column.
    """
    volume = dx * dy * dz
    rmax = 0.0
    for i in range(er.size):
        rmax = max(rmax, er[i])
    index, weight = sphere_buffers(rmax, dx, dy, dz)
    nx, nz = solid.shape[1], solid.shape[2]
    counters = np.zeros(N_COUNTERS, np.int64)
    for i in range(eq.size):
        q = eq[i]
        if q == 0.0:
            continue
        erode = q < 0.0
        radius = er[i]
        r0, r1, c0, c1, k0, k1 = _sphere_box(ex[i], ey[i], ez[i], radius, dx, dy, dz, z0, solid.shape)
        count = 0
        total = 0.0
        for r in range(r0, r1 + 1):
            ddy = r * dy - ey[i]
            for c in range(c0, c1 + 1):
                if not valid[r, c]:
                    continue
                ddx = c * dx - ex[i]
                base = (r * nx + c) * nz
                for k in range(k0, k1 + 1):
                    ddz = z0 + (k + 0.5) * dz - ez[i]
                    d = math.sqrt(ddx * ddx + ddy * ddy + ddz * ddz)
                    if d < radius and solid.flat[base + k] == erode:
                        index[count] = base + k
                        weight[count] = 1.0 - d / radius
                        total += weight[count]
                        count += 1
        if count == 0:
            flat = _nearest(ex[i], ey[i], ez[i], dx, dy, dz, z0, solid.shape)
            step = -1 if erode else 1
            k = flat % nz
            while 0 <= k < nz and solid.flat[flat] != erode:
                k += step
                flat += step
            n = int(alpha * abs(q) / volume)
            if not 0 <= k < nz:
                counters[UNPLACED_HITS] += n
                continue
            index[0] = flat
            weight[0] = 1.0
            total = 1.0
            count = 1
        for j in range(count):
            n = int(alpha * abs(q) * weight[j] / (total * volume))
            if n == 0:
                continue
            counters[EROSION_HITS if erode else DEPOSITION_HITS] += n
            _add_hits(solid, hits, material, index[j], n if erode else -n, threshold, deposit_material,
                      on_erosion, counters)
    return counters
