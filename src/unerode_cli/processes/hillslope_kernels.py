"""Numba kernels of hill-slope diffusion, ∂h/∂t = U + ∇·(k_h ∇h) (001 §6.4), by the
Peaceman–Rachford alternating direction implicit (ADI) scheme.

Finite volumes: cell (r, c) exchanges with its 4 edge neighbours through faces. The flux
through a face, per unit area of the cell, is ``g·(h_neighbour − h)`` with the face
conductance g = k_face/dx² for an east-west face and k_face/dy² for a north-south one (1/y),
k_face the harmonic mean of the two cells' k_h (m²/y). Faces to outside the grid and to nodata
cells have g = 0 (closed). What leaves one cell through a face enters the other, so the sum of
the changes over the domain is the sum of the sources: the scheme conserves mass exactly, up to
rounding.

Conductances are stored padded: ``gx[r, c]`` (shape ny × (nx+1)) is the face between
(r, c−1) and (r, c), ``gy[r, c]`` (shape (ny+1) × nx) the face between (r−1, c) and (r, c);
the outermost faces are 0.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _at(field, r, c, nx):
    """Value of a scalar-or-raster flat field at cell (r, c)."""
    return field[0] if field.size == 1 else field[r * nx + c]


@numba.njit(cache=True, inline="always")
def _harmonic(a, b):
    """Harmonic mean 2ab/(a + b) of two conductivities (m²/y); 0 when either is 0."""
    s = a + b
    return 2.0 * a * b / s if a > 0.0 and b > 0.0 else 0.0


@numba.njit(cache=True)
def face_conductances(k, valid, dx, dy):
    """Face conductances of the finite-volume Laplacian (1/y).

    Args:
        k: float64[ny*nx] k_h (m²/y), or float64[1] for one value everywhere; read on valid
            cells only.
        valid: bool[ny, nx] domain mask.
        dx, dy: east-west and north-south cell sizes (m).

    Returns:
        (gx float64[ny, nx+1], gy float64[ny+1, nx]): k_face/dx² and k_face/dy², 0 on faces
        that touch the grid border or a nodata cell.
    """
    ny, nx = valid.shape
    gx = np.zeros((ny, nx + 1), dtype=np.float64)
    gy = np.zeros((ny + 1, nx), dtype=np.float64)
    ix2 = 1.0 / (dx * dx)
    iy2 = 1.0 / (dy * dy)
    for r in range(ny):
        for c in range(nx):
            if not valid[r, c]:
                continue
            kc = _at(k, r, c, nx)
            if c + 1 < nx and valid[r, c + 1]:
                gx[r, c + 1] = _harmonic(kc, _at(k, r, c + 1, nx)) * ix2
            if r + 1 < ny and valid[r + 1, c]:
                gy[r + 1, c] = _harmonic(kc, _at(k, r + 1, c, nx)) * iy2
    return gx, gy


@numba.njit(cache=True)
def _x_implicit(h, free, gx, gy, uplift, tau, out):
    """First half step: (1 − τ·Lx) h* = (1 + τ·Ly) h + τ·U on free cells, h* = h elsewhere.

    One tridiagonal system per row, solved by the Thomas algorithm (rows are contiguous).
    """
    ny, nx = h.shape
    cp = np.empty(nx, dtype=np.float64)
    dp = np.empty(nx, dtype=np.float64)
    for r in range(ny):
        prev_c = 0.0
        prev_d = 0.0
        for c in range(nx):
            hc = h[r, c]
            if free[r, c]:
                gn = gy[r, c]
                gs = gy[r + 1, c]
                rhs = hc + tau * _at(uplift, r, c, nx)
                if gn > 0.0:
                    rhs += tau * gn * (h[r - 1, c] - hc)
                if gs > 0.0:
                    rhs += tau * gs * (h[r + 1, c] - hc)
                a = -tau * gx[r, c]
                e = -tau * gx[r, c + 1]
                b = 1.0 - a - e
            else:
                rhs = hc
                a = 0.0
                e = 0.0
                b = 1.0
            denom = b - a * prev_c
            prev_c = e / denom
            prev_d = (rhs - a * prev_d) / denom
            cp[c] = prev_c
            dp[c] = prev_d
        x = dp[nx - 1]
        out[r, nx - 1] = x
        for c in range(nx - 2, -1, -1):
            x = dp[c] - cp[c] * x
            out[r, c] = x


@numba.njit(cache=True)
def _y_implicit(h, free, gx, gy, uplift, tau, out):
    """Second half step: (1 − τ·Ly) h⁺ = (1 + τ·Lx) h* + τ·U on free cells, h⁺ = h*
    elsewhere.

    One tridiagonal system per column, solved by the Thomas algorithm on blocks of columns
    eliminated together row after row, so that memory is read contiguously; the modified
    right-hand sides are kept in ``out``, the modified upper diagonals in a small block.
    """
    ny, nx = h.shape
    width = 128
    cp = np.empty((ny, width), dtype=np.float64)
    for c0 in range(0, nx, width):
        c1 = min(nx, c0 + width)
        for r in range(ny):
            for c in range(c0, c1):
                hc = h[r, c]
                if free[r, c]:
                    gw = gx[r, c]
                    ge = gx[r, c + 1]
                    rhs = hc + tau * _at(uplift, r, c, nx)
                    if gw > 0.0:
                        rhs += tau * gw * (h[r, c - 1] - hc)
                    if ge > 0.0:
                        rhs += tau * ge * (h[r, c + 1] - hc)
                    a = -tau * gy[r, c]
                    e = -tau * gy[r + 1, c]
                    b = 1.0 - a - e
                else:
                    rhs = hc
                    a = 0.0
                    e = 0.0
                    b = 1.0
                if r == 0:
                    cp[r, c - c0] = e / b
                    out[r, c] = rhs / b
                else:
                    denom = b - a * cp[r - 1, c - c0]
                    cp[r, c - c0] = e / denom
                    out[r, c] = (rhs - a * out[r - 1, c]) / denom
        for r in range(ny - 2, -1, -1):
            for c in range(c0, c1):
                out[r, c] -= cp[r, c - c0] * out[r + 1, c]


@numba.njit(cache=True)
def adi_step(h, free, gx, gy, uplift, dt):
    """One Peaceman–Rachford step of ∂h/∂t = U + ∇·(k_h ∇h) (001 §6.4), τ = dt/2:

        (1 − τ·Lx) h* = (1 + τ·Ly) hⁿ + τ·U
        (1 − τ·Ly) hⁿ⁺¹ = (1 + τ·Lx) h* + τ·U

    Lx, Ly: the finite-volume east-west and north-south parts of the Laplacian (conductances
    from ``face_conductances``). Each factor is a diagonally dominant tridiagonal matrix, and
    the scheme is unconditionally stable and second order in time. Cells that are not free
    (fixed or nodata) keep their value exactly: identity rows of the systems.

    Args:
        h: float64[ny, nx] elevation hⁿ (m); finite everywhere (nodata cells hold any finite
            value: their faces are closed).
        free: bool[ny, nx] cells that evolve (valid and not fixed).
        gx, gy: padded face conductances (1/y).
        uplift: float64[ny*nx] or float64[1] U (m/y).
        dt: time step (y), ≥ 0.

    Returns:
        float64[ny, nx] hⁿ⁺¹ (m).
    """
    tau = 0.5 * dt
    half = np.empty_like(h)
    _x_implicit(h, free, gx, gy, uplift, tau, half)
    new = np.empty_like(h)
    _y_implicit(half, free, gx, gy, uplift, tau, new)
    return new


@numba.njit(cache=True)
def change_and_budget(h, new, free, uplift, dt):
    """Turn ``new`` (hⁿ⁺¹) into Δh = hⁿ⁺¹ − hⁿ on free cells, 0 elsewhere (m), in place, and
    return it with Σ max(0, −e) and Σ max(0, e) over free cells, e = Δh − U·dt the change due
    to diffusion alone (m; times the cell area: the eroded and deposited volumes)."""
    ny, nx = h.shape
    dh = new
    eroded = 0.0
    deposited = 0.0
    for r in range(ny):
        for c in range(nx):
            if not free[r, c]:
                dh[r, c] = 0.0
                continue
            d = new[r, c] - h[r, c]
            dh[r, c] = d
            e = d - _at(uplift, r, c, nx) * dt
            if e < 0.0:
                eroded -= e
            else:
                deposited += e
    return dh, eroded, deposited
