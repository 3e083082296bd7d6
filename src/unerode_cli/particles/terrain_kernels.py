"""Numba kernels of the terrains particles alter: ground height and normal at a point, and the
alteration of a heightfield (003 §4.1, Eq. 9) or of a layered terrain (003 §4.2, Eq. 10).

Coordinates: x = column·dx (m, east), y = row·dy (m, south), cell centres at integer
column/row; z up (m). Heights between cell centres are bilinear (clamped at the border).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.volume.voxel_kernels import bilinear, cell_frac

#: Bilinear ground height (m) at grid coordinates (col, row) = (x/dx, y/dy).
height_at = bilinear


@numba.njit(cache=True)
def height(h, x, y, dx, dy):
    """Bilinear ground height (m) at (x, y) (m)."""
    return height_at(h, x / dx, y / dy)


@numba.njit(cache=True)
def normal_at(h, col, row, dx, dy):
    """Unit upward normal (n_x, n_y, n_z) of the bilinear surface at grid coordinates
    (col, row) = (x/dx, y/dy)."""
    ny, nx = h.shape
    c, fx = cell_frac(col, nx)
    r, fy = cell_frac(row, ny)
    c1 = min(c + 1, nx - 1)
    r1 = min(r + 1, ny - 1)
    gx = ((h[r, c1] - h[r, c]) * (1.0 - fy) + (h[r1, c1] - h[r1, c]) * fy) / dx if c1 > c else 0.0
    gy = ((h[r1, c] - h[r, c]) * (1.0 - fx) + (h[r1, c1] - h[r, c1]) * fx) / dy if r1 > r else 0.0
    inv = 1.0 / math.sqrt(1.0 + gx * gx + gy * gy)
    return -gx * inv, -gy * inv, inv


@numba.njit(cache=True)
def normal(h, x, y, dx, dy):
    """Unit upward normal (n_x, n_y, n_z) of the bilinear surface at (x, y) (m)."""
    return normal_at(h, x / dx, y / dy, dx, dy)


@numba.njit(cache=True)
def heights(h, xs, ys, dx, dy):
    """``height`` at many points."""
    out = np.empty(xs.size)
    for i in range(xs.size):
        out[i] = height(h, xs[i], ys[i], dx, dy)
    return out


@numba.njit(cache=True)
def normals(h, xs, ys, dx, dy):
    """``normal`` at many points: float64[n, 3]."""
    out = np.empty((xs.size, 3))
    for i in range(xs.size):
        out[i, 0], out[i, 1], out[i, 2] = normal(h, xs[i], ys[i], dx, dy)
    return out


@numba.njit(cache=True)
def footprint(valid, x, y, radius, dx, dy, rows, cols, weights):
    """Cells of the half-sphere of an impact at (x, y): the valid cells whose centre lies within
    ``radius`` (m), weighted by the half-sphere height √(R² − d²) (003 Eq. 9). When no cell
    centre is that close (R small against the cells) the nearest cell takes it all. Fills the
    buffers and returns (count, sum of weights)."""
    ny, nx = valid.shape
    r0 = max(0, int(math.ceil((y - radius) / dy)))
    r1 = min(ny - 1, int(math.floor((y + radius) / dy)))
    c0 = max(0, int(math.ceil((x - radius) / dx)))
    c1 = min(nx - 1, int(math.floor((x + radius) / dx)))
    count = 0
    total = 0.0
    r2 = radius * radius
    for r in range(r0, r1 + 1):
        ddy = r * dy - y
        for c in range(c0, c1 + 1):
            ddx = c * dx - x
            d2 = ddx * ddx + ddy * ddy
            if d2 < r2 and valid[r, c]:
                w = math.sqrt(r2 - d2)
                rows[count] = r
                cols[count] = c
                weights[count] = w
                total += w
                count += 1
    if count == 0:
        rows[0] = min(max(int(round(y / dy)), 0), ny - 1)
        cols[0] = min(max(int(round(x / dx)), 0), nx - 1)
        weights[0] = 1.0
        return 1, 1.0
    return count, total


@numba.njit(cache=True)
def footprint_buffers(radius, dx, dy):
    """Buffers large enough for ``footprint`` of ``radius``."""
    m = (int(2.0 * radius / dy) + 2) * (int(2.0 * radius / dx) + 2)
    return np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m)


@numba.njit(cache=True, inline="always")
def _touches(y, radius, dy, ny, r_lo, r_hi):
    """Whether the footprint of an impact at y (m) of radius R (m) may reach rows
    [r_lo, r_hi) (conservative: it may say True for an impact that does not)."""
    reach = max(radius / dy, 0.5) + 1.0  # the half-sphere, or the nearest cell when R is small
    centre = y / dy
    return centre + reach >= r_lo and centre - reach < r_hi


@numba.njit(cache=True, parallel=True)
def apply_heightfield(h, valid, dx, dy, ex, ey, eq, er, bands=1):
    """Apply the impacts (x, y, Q, R) to the heightfield ``h`` in place, in their order.

    Each impact changes the footprint cells by Δh = Q·√(R² − d²)/(A·Σ√(R² − d²)) (m): the
    scaled half-sphere of 003 Eq. 9, normalised by its sum over the cells rather than by
    2πR³/3, so that Σ Δh·A = Q exactly (mass conservation on a grid; the two agree for R ≫
    cell size). Q > 0 deposits, Q < 0 detaches (m³).

    The rows are split into ``bands`` (one per thread) applied in parallel; each band goes
    through all the impacts in order and changes only its own cells, so every cell receives
    its changes in impact order: the result is the same, bit for bit, for any ``bands``.
    """
    area = dx * dy
    ny = h.shape[0]
    rmax = 0.0
    for i in range(er.size):
        rmax = max(rmax, er[i])
    bands = max(1, min(bands, ny))
    for band in numba.prange(bands):
        r_lo, r_hi = band * ny // bands, (band + 1) * ny // bands
        rows, cols, weights = footprint_buffers(rmax, dx, dy)
        for i in range(eq.size):
            if eq[i] == 0.0 or not _touches(ey[i], er[i], dy, ny, r_lo, r_hi):
                continue
            count, total = footprint(valid, ex[i], ey[i], er[i], dx, dy, rows, cols, weights)
            scale = eq[i] / (area * total)
            for k in range(count):
                if r_lo <= rows[k] < r_hi:
                    h[rows[k], cols[k]] += scale * weights[k]


@numba.njit(cache=True)
def apply_layered(base, thickness, valid, deposit_layer, dx, dy, ex, ey, eq, er):
    """Apply the impacts (x, y, Q, R) to a layered terrain in place, in their order (003 §4.2).

    The footprint and Δh are those of ``apply_heightfield`` (003 Eq. 10). Deposition (Δh > 0)
    thickens layer ``deposit_layer`` (the top layer, of the deposit material); detachment
    removes matter from the top layer down, and below the bottom of the stack from the bottom
    layer's material, whose base elevation ``base`` then lowers. The surface base + Σ thickness
    changes by exactly Δh.
    """
    area = dx * dy
    n_layers = thickness.shape[0]
    rmax = 0.0
    for i in range(er.size):
        rmax = max(rmax, er[i])
    rows, cols, weights = footprint_buffers(rmax, dx, dy)
    for i in range(eq.size):
        if eq[i] == 0.0:
            continue
        count, total = footprint(valid, ex[i], ey[i], er[i], dx, dy, rows, cols, weights)
        scale = eq[i] / (area * total)
        for k in range(count):
            r, c = rows[k], cols[k]
            dh = scale * weights[k]
            if dh > 0.0:
                thickness[deposit_layer, r, c] += dh
                continue
            rest = -dh
            for layer in range(n_layers - 1, -1, -1):
                take = min(thickness[layer, r, c], rest)
                thickness[layer, r, c] -= take
                rest -= take
                if rest <= 0.0:
                    break
            if rest > 0.0:
                base[r, c] -= rest


@numba.njit(cache=True)
def top_material(thickness, layer_material):
    """Material index of the top non-empty layer of each cell (int32[ny, nx]); the bottom
    layer's material where the whole stack is empty."""
    n_layers, ny, nx = thickness.shape
    out = np.empty((ny, nx), np.int32)
    for r in range(ny):
        for c in range(nx):
            m = layer_material[0]
            for layer in range(n_layers - 1, -1, -1):
                if thickness[layer, r, c] > 0.0:
                    m = layer_material[layer]
                    break
            out[r, c] = m
    return out
