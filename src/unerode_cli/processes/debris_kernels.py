"""Numba kernels of debris-flow erosion (001 Eq. 8), implicit along the steepest descent,
downstream cells first (Braun & Willett 2013).

Arrays are flattened row-major (row 0 = north); the flat index of cell (row, col) is
``row * nx + col``. Fields (k_df) are flat float64 arrays of size ny*nx, or of size 1 for a
value that is the same everywhere.
"""

from __future__ import annotations

import numba
import numpy as np

from unerode_cli.hydro.kernels import DCOL, DROW


@numba.njit(cache=True, inline="always")
def _at(field, i):
    """Value of a scalar-or-raster field at flat index ``i``."""
    return field[0] if field.size == 1 else field[i]


@numba.njit(cache=True, inline="always")
def _power(x, p):
    """x^p for x ≥ 0, exact and fast for p = 1 and p = 2."""
    if p == 2.0:
        return x * x
    if p == 1.0:
        return x
    return x**p


@numba.njit(cache=True)
def excess_slope(length, c, b, p):
    """The root x ≥ 0 of g(x) = length·x + c·x^p − b, for b > 0, length > 0, c ≥ 0, p ≥ 1.

    x is the slope above the critical one, (h − h_r)/L − s_c, that the implicit step leaves
    (see ``debris_sweep``). g is increasing and convex, g(0) = −b < 0, so the root is unique
    and lies in [0, min(b/L, (b/c)^(1/p))]. Closed forms for p = 1 and p = 2; otherwise
    Newton from the upper end of the bracket (which, g being convex, approaches the root from
    above without overshoot), kept inside the bracket by bisection against rounding.
    """
    if c <= 0.0:
        return b / length
    if p == 1.0:
        return b / (length + c)
    if p == 2.0:
        return 2.0 * b / (length + np.sqrt(length * length + 4.0 * c * b))
    lo = 0.0
    hi = min(b / length, (b / c) ** (1.0 / p))
    x = hi
    for _ in range(200):
        g = length * x + c * x**p - b
        if g > 0.0:
            hi = x
        elif g < 0.0:
            lo = x
        else:
            return x
        xn = x - g / (length + p * c * x ** (p - 1.0))
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 4e-16 * x or hi - lo <= 4e-16 * hi:
            return xn
        x = xn
    return x


@numba.njit(cache=True, inline="always")
def _lowering(b, lengths, best, best_b, c, q_slope):
    """The lowering (m) of a cell by one implicit step (``debris_sweep``): the largest of the
    one-neighbour lowerings min(c·x_k^q', b_k), x_k = ``excess_slope``(L_k, c, b_k, q'), over the
    neighbours k with b_k > 0, c = dt·K' (m). ``best`` is the neighbour of the largest b (m),
    ``best_b``; solved first, it rules most other neighbours out without a solve."""
    x = excess_slope(lengths[best], c, best_b, q_slope)
    lowering = min(c * _power(x, q_slope), best_b)
    for k in range(8):
        if k == best or b[k] <= lowering:  # its root is not below h0 − lowering
            continue
        x = excess_slope(lengths[k], c, b[k], q_slope)
        lowering = max(lowering, min(c * _power(x, q_slope), b[k]))
    return lowering


@numba.njit(cache=True)
def debris_sweep(h, fixed, order, area, dx, dy, k_df, k_da, q_area, q_slope, s_c, dt):
    """One implicit step of ∂z/∂t = −k_df·(1 + k_da·A^q)·max(0, |∇z| − s_c)^q' (001 Eq. 8).

    Cells are solved downstream first (``order`` read backwards, Braun & Willett 2013), so
    when cell i is solved its D8 receiver, and every other neighbour j that comes after it in
    ``order``, already has its new elevation h_j⁺. |∇z| is the steepest-descent (D8) slope
    at the end of the step towards those neighbours, S⁺ = max_j (h − h_j⁺)/L_j (L_j = dx, dy,
    or sqrt(dx² + dy²) on diagonals), and the new h solves

        h − h0 + dt·K'·max(0, S⁺(h) − s_c)^q' = 0,    K' = k_df·(1 + k_da·A^q).

    The left side is the maximum over j of the same expression with one neighbour j, each
    increasing in h, so its root is the lowest of the one-neighbour roots. For one neighbour,
    nothing happens when (h0 − h_j⁺)/L_j ≤ s_c; otherwise h = h_j⁺ + L_j·(s_c + x) with
    L_j·x + dt·K'·x^q' = b_j, b_j = h0 − h_j⁺ − L_j·s_c > 0 (``excess_slope``), and
    Δh = −dt·K'·x^q' ∈ [−b_j, 0]. So whatever dt, a cell is lowered, never below the
    critical slope over its new steepest-descent neighbour (no overshoot, no new pit), and a
    very long step leaves it at the critical slope. Fixed cells (outlets) keep their elevation.

    Taking the receiver at the end of the step among all the neighbours already solved, rather
    than freezing the D8 receiver of the start of the step, keeps long steps from cutting
    cliffs across divides (neighbours draining to different outlets along paths of different
    lengths); with small steps both give the same result.

    Args:
        h: float64[ny, nx] elevation h0 (m); read on cells of ``order`` only.
        fixed: bool[ny, nx] cells that keep their elevation (outlets, base level).
        order: flat indices (int32 or int64) of the valid cells, every cell before its receivers
            (``Routing.order``); cells not in it (nodata) are never read.
        area: float64[ny*nx] drainage area A (m²).
        dx, dy: east-west and north-south cell sizes (m).
        k_df: float64[ny*nx] or float64[1] k_df (m/y).
        k_da: k_da (m^(−2q)); q_area: q; q_slope: q' ≥ 1; s_c: critical slope (m/m).
        dt: time step (y), ≥ 0.

    Returns:
        float64[ny*nx] Δh (m), ≤ 0; 0 on fixed cells and on cells not in ``order``.
    """
    ny, nx = h.shape
    z = h.ravel()
    out = fixed.ravel()
    diagonal = np.sqrt(dx * dx + dy * dy)
    lengths = np.array([diagonal, dy, diagonal, dx, dx, diagonal, dy, diagonal])
    offsets = DROW * nx + DCOL
    # new elevations; +inf until solved, so that a neighbour not yet solved is never lower
    new = np.full(ny * nx, np.inf)
    dh = np.zeros(ny * nx, dtype=np.float64)
    b = np.empty(8, dtype=np.float64)
    for idx in range(order.size - 1, -1, -1):
        i = order[idx]
        h0 = z[i]
        new[i] = h0
        if out[i]:
            continue
        r0 = i // nx
        c0 = i - r0 * nx
        interior = 0 < r0 < ny - 1 and 0 < c0 < nx - 1
        # b_k = h0 − h_k⁺ − L_k·s_c for the neighbours (−inf for those not solved yet)
        best = -1
        best_b = 0.0
        for k in range(8):
            bk = -np.inf
            if interior or (0 <= r0 + DROW[k] < ny and 0 <= c0 + DCOL[k] < nx):
                bk = h0 - new[i + offsets[k]] - lengths[k] * s_c
            b[k] = bk
            if bk > best_b:
                best_b = bk
                best = k
        if best < 0:
            continue
        c = dt * _at(k_df, i) * (1.0 + k_da * area[i] ** q_area)
        if c <= 0.0:
            continue
        lowering = _lowering(b, lengths, best, best_b, c, q_slope)
        if lowering > 0.0:
            dh[i] = -lowering
            new[i] = h0 - lowering
    return dh
