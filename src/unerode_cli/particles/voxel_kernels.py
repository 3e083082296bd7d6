"""Numba ground queries of voxel terrains for the particle tracer (003 §4: a representation must
tell where a particle meets the ground and the ground's normal there).

The tracer reads a frozen float32 level f[row, column, layer] (density voxels as they are,
binary voxels as ±1) of ``volume.voxels``'s layout, positive in the ground, with the ground
surface at f = 0 (003 §4.4). Between voxel centres f is trilinear; horizontally it is clamped
at the border (as heightfields are), below the bottom layer it is the bottom layer's value and
above the top layer it is air (−1). Coordinates are the tracer's: x = column·dx, y = row·dy,
z (m) with voxel k's centre at z0 + (k + ½)·dz. When impacts alter the ground as they happen
(per-impact application, 003 §3), ``refresh`` brings the tracer's level and top surface up to
date around each one.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.volume.voxel_kernels import cell_frac, column_top

#: Newton steps of ``project``, the longest move of one (in voxels) and the level below which
#: a point is on the surface (a thousandth of a voxel of a unit-slope density).
_NEWTON_STEPS = 3
_MAX_NEWTON_MOVE = 1.0
_LEVEL_TOLERANCE = 1e-3


@numba.njit(cache=True, inline="always")
def _layer_frac(kk, nz):
    """Lower layer index (−1 … nz) and fraction of a layer coordinate ``kk`` (centres at
    integers); out of [−1, nz] the value is that of the boundary anyway."""
    kk = min(max(kk, -1.0), float(nz))
    k = int(math.floor(kk))
    return k, kk - k


@numba.njit(cache=True, inline="always")
def _value(vol, r, c, k):
    """f at voxel (r, c, k): air (−1) above the grid, the bottom layer's value below it."""
    if k >= vol.shape[2]:
        return -1.0
    return float(vol[r, c, max(k, 0)])


@numba.njit(cache=True)
def level_at(vol, col, row, kk):
    """Trilinear f at grid coordinates (col, row) = (x/dx, y/dy) and layer coordinate
    kk = (z − z0)/dz − ½ (dimensionless; > 0 in the ground)."""
    ny, nx, nz = vol.shape
    c, fx = cell_frac(col, nx)
    r, fy = cell_frac(row, ny)
    k, fz = _layer_frac(kk, nz)
    c1 = min(c + 1, nx - 1)
    r1 = min(r + 1, ny - 1)
    if 0 <= k and k + 1 < nz:  # inside the grid: no boundary rule to apply
        lo = ((vol[r, c, k] * (1.0 - fx) + vol[r, c1, k] * fx) * (1.0 - fy)
              + (vol[r1, c, k] * (1.0 - fx) + vol[r1, c1, k] * fx) * fy)
        hi = ((vol[r, c, k + 1] * (1.0 - fx) + vol[r, c1, k + 1] * fx) * (1.0 - fy)
              + (vol[r1, c, k + 1] * (1.0 - fx) + vol[r1, c1, k + 1] * fx) * fy)
        return lo * (1.0 - fz) + hi * fz
    lo = ((_value(vol, r, c, k) * (1.0 - fx) + _value(vol, r, c1, k) * fx) * (1.0 - fy)
          + (_value(vol, r1, c, k) * (1.0 - fx) + _value(vol, r1, c1, k) * fx) * fy)
    hi = ((_value(vol, r, c, k + 1) * (1.0 - fx) + _value(vol, r, c1, k + 1) * fx) * (1.0 - fy)
          + (_value(vol, r1, c, k + 1) * (1.0 - fx) + _value(vol, r1, c1, k + 1) * fx) * fy)
    return lo * (1.0 - fz) + hi * fz


@numba.njit(cache=True)
def level_and_gradient(vol, col, row, kk, dx, dy, dz):
    """Trilinear f and its gradient ∇f (1/m) at (col, row, kk) (see ``level_at``).
    Returns (f, ∂f/∂x, ∂f/∂y, ∂f/∂z); a derivative across a clamped border is 0."""
    ny, nx, nz = vol.shape
    c, fx = cell_frac(col, nx)
    r, fy = cell_frac(row, ny)
    k, fz = _layer_frac(kk, nz)
    c1 = min(c + 1, nx - 1)
    r1 = min(r + 1, ny - 1)
    v000, v001 = _value(vol, r, c, k), _value(vol, r, c1, k)
    v010, v011 = _value(vol, r1, c, k), _value(vol, r1, c1, k)
    v100, v101 = _value(vol, r, c, k + 1), _value(vol, r, c1, k + 1)
    v110, v111 = _value(vol, r1, c, k + 1), _value(vol, r1, c1, k + 1)
    lo_y0 = v000 * (1.0 - fx) + v001 * fx
    lo_y1 = v010 * (1.0 - fx) + v011 * fx
    hi_y0 = v100 * (1.0 - fx) + v101 * fx
    hi_y1 = v110 * (1.0 - fx) + v111 * fx
    lo = lo_y0 * (1.0 - fy) + lo_y1 * fy
    hi = hi_y0 * (1.0 - fy) + hi_y1 * fy
    value = lo * (1.0 - fz) + hi * fz
    gx = 0.0
    if c1 > c:
        d_lo = (v001 - v000) * (1.0 - fy) + (v011 - v010) * fy
        d_hi = (v101 - v100) * (1.0 - fy) + (v111 - v110) * fy
        gx = (d_lo * (1.0 - fz) + d_hi * fz) / dx
    gy = 0.0
    if r1 > r:
        gy = ((lo_y1 - lo_y0) * (1.0 - fz) + (hi_y1 - hi_y0) * fz) / dy
    return value, gx, gy, (hi - lo) / dz


@numba.njit(cache=True, inline="always")
def _outward(gx, gy, gz):
    """−∇f/‖∇f‖, straight up where the gradient vanishes (deep in the ground or in the air)."""
    norm = math.sqrt(gx * gx + gy * gy + gz * gz)
    if norm == 0.0:
        return 0.0, 0.0, 1.0
    return -gx / norm, -gy / norm, -gz / norm


@numba.njit(cache=True)
def normal_at(vol, x, y, z, dx, dy, dz, z0):
    """Unit outward normal −∇f/‖∇f‖ of the ground at (x, y, z) (m; 003 §4)."""
    _, gx, gy, gz = level_and_gradient(vol, x / dx, y / dy, (z - z0) / dz - 0.5, dx, dy, dz)
    return _outward(gx, gy, gz)


@numba.njit(cache=True)
def project(vol, x, y, z, dx, dy, dz, z0):
    """The point of the f = 0 surface near (x, y, z) (m) and the outward normal there: Newton
    steps along ∇f (at most ``_NEWTON_STEPS``, each moving at most a voxel, until |f| is below
    ``_LEVEL_TOLERANCE``); the point is kept where the gradient vanishes.
    Returns (x, y, z, n_x, n_y, n_z)."""
    limit = _MAX_NEWTON_MOVE * min(dx, dy, dz)
    gx, gy, gz = 0.0, 0.0, 0.0
    for _ in range(_NEWTON_STEPS):
        value, gx, gy, gz = level_and_gradient(vol, x / dx, y / dy, (z - z0) / dz - 0.5, dx, dy, dz)
        g2 = gx * gx + gy * gy + gz * gz
        if abs(value) <= _LEVEL_TOLERANCE or g2 == 0.0:
            break
        s = value / g2
        move = abs(s) * math.sqrt(g2)
        if move > limit:
            s *= limit / move
        x -= s * gx
        y -= s * gy
        z -= s * gz
    nx_, ny_, nz_ = _outward(gx, gy, gz)
    return x, y, z, nx_, ny_, nz_


@numba.njit(cache=True)
def material_at(vmat, x, y, z, nx_, ny_, nz_, dx, dy, dz, z0):
    """Material index of the voxel half a voxel inside the ground from (x, y, z) along the
    outward normal (nx_, ny_, nz_); 0 when ``vmat`` is empty (one material)."""
    if vmat.size == 0:
        return 0
    ny, nx, nz = vmat.shape
    depth = 0.5 * min(dx, dy, dz)
    r = min(max(int(round((y - depth * ny_) / dy)), 0), ny - 1)
    c = min(max(int(round((x - depth * nx_) / dx)), 0), nx - 1)
    k = min(max(int(math.floor((z - depth * nz_ - z0) / dz)), 0), nz - 1)
    return vmat[r, c, k]


@numba.njit(cache=True)
def levels(vol, xs, ys, zs, dx, dy, dz, z0):
    """``level_at`` at many points (m): float64[n]."""
    out = np.empty(xs.size)
    for i in range(xs.size):
        out[i] = level_at(vol, xs[i] / dx, ys[i] / dy, (zs[i] - z0) / dz - 0.5)
    return out


@numba.njit(cache=True)
def normals(vol, xs, ys, zs, dx, dy, dz, z0):
    """``normal_at`` at many points (m): float64[n, 3]."""
    out = np.empty((xs.size, 3))
    for i in range(xs.size):
        out[i, 0], out[i, 1], out[i, 2] = normal_at(vol, xs[i], ys[i], zs[i], dx, dy, dz, z0)
    return out


@numba.njit(cache=True)
def refresh(vol, h, valid, state, binary, x, y, reach, dx, dy, z0, dz):
    """Copy the voxels of the valid columns within ``reach`` (m) of (x, y) (and the nearest
    one) from the terrain's ``state`` — a density, or with ``binary`` a solid mask read as ±1 —
    into the tracer's float32 level ``vol``, and their top surface (m) into ``h``."""
    ny, nx, nz = vol.shape
    r0 = max(0, int(math.floor((y - reach) / dy)) - 1)
    r1 = min(ny - 1, int(math.ceil((y + reach) / dy)) + 1)
    c0 = max(0, int(math.floor((x - reach) / dx)) - 1)
    c1 = min(nx - 1, int(math.ceil((x + reach) / dx)) + 1)
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            if not valid[r, c]:
                continue
            for k in range(nz):
                if binary:
                    vol[r, c, k] = 1.0 if state[r, c, k] else -1.0
                else:
                    vol[r, c, k] = state[r, c, k]
            h[r, c] = column_top(vol, r, c, z0, dz)


@numba.njit(cache=True)
def ground_below(vol, x, y, z, dx, dy, dz, z0):
    """Elevation (m) of the ground straight below (x, y, z) (m): z itself in the ground, else
    where f, sampled every half voxel down the vertical, turns ≥ 0 (linear between samples);
    z0, the bottom of the grid, when there is none."""
    col, row = x / dx, y / dy
    g = level_at(vol, col, row, (z - z0) / dz - 0.5)
    if g >= 0.0:
        return z
    step = 0.5 * dz
    while z > z0:
        g1 = level_at(vol, col, row, (z - step - z0) / dz - 0.5)
        if g1 >= 0.0:
            return z - step * g / (g - g1)
        z -= step
        g = g1
    return z0
