"""Numba kernels of the Picard column preconditioner of the Blatter–Pattyn minimisation (001 Eq. 7).

T is the Picard (frozen-viscosity) Hessian of the energy E (Pa·m³/y, ``blatter_energy``) kept
only between unknowns of one lattice column: a tridiagonal matrix along every column, u and v
apart, over the unknowns x = [u_dof, v_dof] (m/y). ``picard_columns`` assembles it (diagonal and
upper band, in Pa·m³/y per (m/y)²), ``column_chains`` lists each column's unknowns bottom up,
``column_factor`` takes its Thomas factorisation (pivots floored at ``PIVOT_FLOOR``) and
``column_solve_factored`` applies T⁻¹, the columns of a level on threads for large lattices.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.glacier.blatter_energy import basal_face, cell_geometry, expand, terrain_following_gradient


@numba.njit(cache=True, inline="always")
def _add_cell_couplings(u, v, dof, zeta, dx, dy, tilt, b_visc, p, eps2, periodic, diag, upper):
    """Add each lattice cell's Picard coupling within a column (``picard_columns``) to ``diag``
    and ``upper``, float64[2n] over x = [u_dof, v_dof]: w·(4α_x,a α_x,b + α_y,a α_y,b +
    α_z,a α_z,b) for u (x ↔ y for v), w = area·c_t·½·B·max(|D|², eps2)^(p/2 − 1); a pair whose
    two corners share an unknown (collapsed levels) adds twice its coupling to the diagonal."""
    nz, ny, nx = u.shape
    n = diag.size // 2
    ncx = nx if periodic else nx - 1
    ncy = ny if periodic else ny - 1
    area = dx * dy
    for k in range(nz - 1):
        for j in range(ncy):
            j1 = j + 1 if j + 1 < ny else 0
            for i in range(ncx):
                i1 = i + 1 if i + 1 < nx else 0
                ct, ax, ay = cell_geometry(zeta, k, j, i, j1, i1, dx, dy, tilt)
                if ct <= 0.0:
                    continue
                ux, uy, uz = terrain_following_gradient(u, k, j, i, j1, i1, dx, dy, ct, ax, ay)
                vx, vy, vz = terrain_following_gradient(v, k, j, i, j1, i1, dx, dy, ct, ax, ay)
                dxy = 0.5 * (uy + vx)
                d2 = 2.0 * (ux * ux + vy * vy + ux * vy + dxy * dxy + 0.25 * (uz * uz + vz * vz))
                w = area * ct * 0.5 * b_visc * max(d2, eps2) ** (0.5 * p - 1.0)
                az = 1.0 / (4.0 * ct)  # α_z is −az at the corner below, +az above
                for bb in range(2):
                    jj = j1 if bb else j
                    for a in range(2):
                        ii = i1 if a else i
                        hx, hy = (2 * a - 1) / (4.0 * dx), (2 * bb - 1) / (4.0 * dy)
                        xb, yb = hx + ax * az, hy + ay * az
                        xt, yt = hx - ax * az, hy - ay * az
                        below, above = dof[k, jj, ii], dof[k + 1, jj, ii]
                        if below >= 0:
                            diag[below] += w * (4.0 * xb * xb + yb * yb + az * az)
                            diag[n + below] += w * (xb * xb + 4.0 * yb * yb + az * az)
                        if above >= 0:
                            diag[above] += w * (4.0 * xt * xt + yt * yt + az * az)
                            diag[n + above] += w * (xt * xt + 4.0 * yt * yt + az * az)
                        if below >= 0 and above >= 0:
                            cu = w * (4.0 * xb * xt + yb * yt - az * az)
                            cv = w * (xb * xt + 4.0 * yb * yt - az * az)
                            if below != above:
                                upper[below] += cu
                                upper[n + below] += cv
                            else:
                                diag[below] += 2.0 * cu
                                diag[n + below] += 2.0 * cv


@numba.njit(cache=True, inline="always")
def _add_basal_couplings(u, v, dof, zeta, c_face, dx, dy, tilt, sigma, ureg2, periodic, diag):
    """Add each basal face's sliding term w_s·2(1 + ∂x b²)/16 (u; ∂y b for v) to the diagonal
    ``diag`` of its corners' unknowns, w_s = area·√(1 + |∂b|²)·C·½·max(|u_b|_M², ureg2)^(σ/2 − 1)
    (``picard_columns``)."""
    _, ny, nx = u.shape
    n = diag.size // 2
    ncx = nx if periodic else nx - 1
    ncy = ny if periodic else ny - 1
    area = dx * dy
    for j in range(ncy):
        j1 = j + 1 if j + 1 < ny else 0
        for i in range(ncx):
            cf = c_face[j, i]
            if cf <= 0.0:
                continue
            i1 = i + 1 if i + 1 < nx else 0
            bx, by, ub, vb, t = basal_face(zeta, u, v, j, i, j1, i1, dx, dy, tilt)
            ws = (area * math.sqrt(1.0 + bx * bx + by * by) * cf * 0.5
                  * max(ub * ub + vb * vb + t * t, ureg2) ** (0.5 * sigma - 1.0))
            for bb in range(2):
                jj = j1 if bb else j
                for a in range(2):
                    d = dof[0, jj, i1 if a else i]
                    if d >= 0:
                        diag[d] += ws * 2.0 * (1.0 + bx * bx) / 16.0
                        diag[n + d] += ws * 2.0 * (1.0 + by * by) / 16.0


@numba.njit(cache=True)
def picard_columns(x, dof, zeta, c_face, dx, dy, tilt, b_visc, p, sigma, eps2, ureg2, periodic):
    """The Picard (frozen-viscosity) Hessian of E restricted to each lattice column: the
    preconditioner of the minimisation (a vertical-line relaxation; thin lattice cells couple
    the levels of a column far more strongly than neighbouring columns).

    A cell couples each u unknown of corners a, b through w·(4α_x,a α_x,b + α_y,a α_y,b +
    α_z,a α_z,b) (x ↔ y for v), with w = ∂E/∂|D|² at the current velocities and α_x, α_y, α_z
    the corner weights in ∂x u, ∂y u, ∂z u (``blatter_energy``'s module docstring); only pairs
    in one column (the corner below and above, or one corner with itself) are kept
    (``_add_cell_couplings``). Each basal face adds w_s·2(1 + ∂x b²)/16 (w_s = ∂E/∂|u_b|_M²)
    to its corners' diagonal (``_add_basal_couplings``). Collapsed levels that share an unknown
    add their coupling to its diagonal. ``eps2`` and ``ureg2`` here are floors of |D|² and
    |u_b|_M² (they bound w and w_s).

    Returns:
        (diag, upper), float64[2n] each over the unknowns x = [u_dof, v_dof]: the diagonal (the
        largest one where no cell touches an unknown), and the coupling of each unknown with
        the next one up its column (0 at the top).
    """
    u, v = expand(x, dof)
    n = x.size // 2
    diag = np.zeros(2 * n)
    upper = np.zeros(2 * n)
    _add_cell_couplings(u, v, dof, zeta, dx, dy, tilt, b_visc, p, eps2, periodic, diag, upper)
    _add_basal_couplings(u, v, dof, zeta, c_face, dx, dy, tilt, sigma, ureg2, periodic, diag)
    # unknowns that no cell of positive volume touches: any positive diagonal keeps T definite
    largest = diag.max()
    for d in range(2 * n):
        if diag[d] <= 0.0:
            diag[d] = largest
    return diag, upper


@numba.njit(cache=True)
def column_chains(dof):
    """int64[N+1, columns]: the distinct unknowns of every column that has any, bottom up
    along axis 0, padded with −1 (collapsed levels share their unknown, a frozen bed has
    none). Unknowns are numbered level by level, so a row of this table reads them nearly in
    order."""
    nz, ny, nx = dof.shape
    chains = np.full((nz, ny * nx), -1, np.int64)
    count = 0
    for j in range(ny):
        for i in range(nx):
            m = 0
            prev = -1
            for k in range(nz):
                d = dof[k, j, i]
                if d < 0 or d == prev:
                    continue
                chains[m, count] = d
                m += 1
                prev = d
            if m > 0:
                count += 1
    return np.ascontiguousarray(chains[:, :count])


#: Smallest Thomas pivot, relative to its diagonal entry. Very thin cells (c_t → 0) make a
#: column's matrix nearly singular along the column (α_z ≫ α_x), and the pivots then lose
#: all their digits to cancellation; a floor keeps the preconditioner positive definite.
PIVOT_FLOOR = 1e-10


@numba.njit(cache=True, error_model="numpy")
def column_factor(diag, upper, chains):
    """The Thomas factorisation of T (``picard_columns``) along every column, u and v apart:
    (1 / pivot, upper / pivot), float64[2n] each, pivots floored at PIVOT_FLOOR × their diagonal.
    It does not depend on the right-hand side, so each preconditioner is factorised once."""
    n = diag.size // 2
    nz, ncol = chains.shape
    inv = np.empty(2 * n)
    ratio = np.empty(2 * n)
    for q in range(nz):
        for half in range(2):
            off = half * n
            for col in range(ncol):
                d = chains[q, col]
                if d < 0:
                    continue
                pivot = diag[off + d]
                if q > 0:
                    below = chains[q - 1, col]
                    pivot -= upper[off + below] * ratio[off + below]
                pivot = max(pivot, PIVOT_FLOOR * diag[off + d])
                inv[off + d] = 1.0 / pivot
                ratio[off + d] = upper[off + d] / pivot
    return inv, ratio



#: Vectors of at least this many unknowns have the column solves and L-BFGS's passes
#: (``lbfgs_kernels``: ``dot``, ``_add_scaled_dot``, ``new_pair``) run on threads.
PARALLEL_MIN_UNKNOWNS = 200_000



@numba.njit(cache=True, inline="always")
def _forward(inv, upper, chains, r, out, q, off, col):
    d = chains[q, col]
    if d >= 0:
        rhs = r[off + d]
        if q > 0:
            below = chains[q - 1, col]
            rhs -= upper[off + below] * out[off + below]
        out[off + d] = rhs * inv[off + d]


@numba.njit(cache=True, inline="always")
def _backward(ratio, chains, out, q, off, col):
    d = chains[q, col]
    above = chains[q + 1, col]
    if d >= 0 and above >= 0:
        out[off + d] -= ratio[off + d] * out[off + above]


@numba.njit(cache=True, parallel=True)
def _column_solve_threads(inv, ratio, upper, chains, r, out):
    n = inv.size // 2
    nz, ncol = chains.shape
    for q in range(nz):
        for col in numba.prange(ncol):
            _forward(inv, upper, chains, r, out, q, 0, col)
            _forward(inv, upper, chains, r, out, q, n, col)
    for q in range(nz - 2, -1, -1):
        for col in numba.prange(ncol):
            _backward(ratio, chains, out, q, 0, col)
            _backward(ratio, chains, out, q, n, col)


@numba.njit(cache=True)
def column_solve_factored(inv, ratio, upper, chains, r, out):
    """out = T⁻¹·r from ``column_factor``'s (inv, ratio): forward elimination, back substitution,
    level by level over all columns at once (the columns of a level on threads from
    PARALLEL_MIN_UNKNOWNS unknowns: they are independent, so the result is the same)."""
    if inv.size >= PARALLEL_MIN_UNKNOWNS:
        _column_solve_threads(inv, ratio, upper, chains, r, out)
        return out
    n = inv.size // 2
    nz, ncol = chains.shape
    for q in range(nz):
        for col in range(ncol):
            _forward(inv, upper, chains, r, out, q, 0, col)
            _forward(inv, upper, chains, r, out, q, n, col)
    for q in range(nz - 2, -1, -1):
        for col in range(ncol):
            _backward(ratio, chains, out, q, 0, col)
            _backward(ratio, chains, out, q, n, col)
    return out


@numba.njit(cache=True)
def column_solve(diag, upper, chains, r, out):
    """out = T⁻¹·r for T tridiagonal along every column (``picard_columns``), u and v apart:
    the Thomas algorithm (``column_factor`` then ``column_solve_factored``), pivots floored at
    PIVOT_FLOOR × their diagonal."""
    inv, ratio = column_factor(diag, upper, chains)
    return column_solve_factored(inv, ratio, upper, chains, r, out)
