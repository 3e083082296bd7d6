"""Numba kernels of the Blatter–Pattyn energy (001 Eq. 7) and its analytic gradient.

Discretisation (001 §4.2 and Appendix A): horizontal velocities (u, v) (m/y) live on the nodes
of the terrain-following lattice ζ[k, j, i] (``lattice``); every lattice cell, a hexahedron
with vertical edges between columns (i, i+1) × (j, j+1) and levels (k, k+1), is one linear
(trilinear) finite element evaluated at its centre (one-point quadrature), with the averaging
(a) and difference (d) operators of 001 Appendix A:

    c_t   = a_x a_y d_z ζ                       cell thickness (m)
    V     = dx·dy·c_t                           cell volume (m³)
    u_c   = a_x a_y a_z u                       velocity at the centre
    ∂z u  = (a_x a_y d_z u) / c_t
    ∂x u  = (d_x a_y a_z u)/dx − (d_x a_y a_z ζ)/dx · ∂z u
    ∂y u  = (a_x d_y a_z u)/dy − (a_x d_y a_z ζ)/dy · ∂z u

The horizontal gradients are the chain rule of the terrain-following coordinates, i.e. the
exact gradient of the isoparametric trilinear element at its centre. (001 Eq. 9–10 as
printed do not vanish for a uniform velocity, so they are not used verbatim. The volume is the
exact volume dx·dy·c_t of the cell rather than 001's inclined face area f_a times c_t.)

Energy (001 Eq. 7), velocities in m/y and stresses in Pa, so in Pa·m³/y:

    E = Σ_cells V·[ (B/p)·(|D|² + ε²)^(p/2) + ρg·(∂x s·u_c + ∂y s·v_c) ]
      + Σ_basal faces dx·dy·√(1 + |∇b|²)·(C/σ)·(|u_b|_M² + u_ε²)^(σ/2)

with the first-order strain-rate tensor D (001 §4.1; D_zz = −D_xx − D_yy)

    |D|² = D:D = 2·(D_xx² + D_yy² + D_xx·D_yy + D_xy² + D_xz² + D_yz²),
    D_xx = ∂x u, D_yy = ∂y v, D_xy = (∂y u + ∂x v)/2, D_xz = ∂z u/2, D_yz = ∂z v/2,

∂x s, ∂y s the surface gradient at the cell centre, u_b = a_x a_y u at the bed and the bed-
tangential norm |u_b|_M² = u_b² + v_b² + (u_b·∂x b + v_b·∂y b)². ε (1/y) and u_ε (m/y) are
small regularisations that make the energy twice differentiable at zero strain rate and
zero sliding. The sliding term is integrated over the area of the bed (001 Eq. 7's dS over Γ),
dx·dy·√(1 + |∇b|²) per face, not over its plan view dx·dy: on an inclined slab this gives the
exact Weertman speed |u_b| = (ρgH·sin α·cos α / C)^(1/(σ−1)) along the bed (H vertical), where
the plan-view area would slide 1/cos²α faster for σ = 3/2 (×1.33 on 30°, ×2.4 on 50°: thin ice on
steep walls, where real DEMs have it). ``tilt`` = tan(background slope) is a uniform inclination
along +x: the true elevations are ζ − x·tilt, which enters ∂x ζ, ∂x s and ∂x b.

Domain edges: ``periodic`` wraps cells around both axes (a grid of nx columns has nx cells
along x), otherwise the edge faces are stress free (nx − 1 cells).
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def cell_geometry(zeta, k, j, i, j1, i1, dx, dy, tilt):
    """Lattice cell between levels k and k+1 over columns (j, i)..(j1, i1): its mean thickness
    c_t (m) and the slopes a_x (tilt included), a_y of its mid-surface (001 Appendix A)."""
    zb00, zb01, zb10, zb11 = zeta[k, j, i], zeta[k, j, i1], zeta[k, j1, i], zeta[k, j1, i1]
    zt00, zt01 = zeta[k + 1, j, i], zeta[k + 1, j, i1]
    zt10, zt11 = zeta[k + 1, j1, i], zeta[k + 1, j1, i1]
    ct = 0.25 * ((zt00 + zt01 + zt10 + zt11) - (zb00 + zb01 + zb10 + zb11))
    ax = (0.25 * ((zb01 - zb00) + (zb11 - zb10) + (zt01 - zt00) + (zt11 - zt10)) - dx * tilt) / dx
    ay = 0.25 * ((zb10 - zb00) + (zb11 - zb01) + (zt10 - zt00) + (zt11 - zt01)) / dy
    return ct, ax, ay


@numba.njit(cache=True, inline="always")
def surface_slope(zeta, j, i, j1, i1, rdx, rdy, tilt):
    """(∂x s, ∂y s) of the ice surface (the lattice's top level) at the centre of the cell
    columns (j, i)..(j1, i1), tilt included; rdx, rdy are 1/dx, 1/dy (1/m)."""
    top = zeta.shape[0] - 1
    s00, s01, s10, s11 = zeta[top, j, i], zeta[top, j, i1], zeta[top, j1, i], zeta[top, j1, i1]
    return 0.5 * ((s01 - s00) + (s11 - s10)) * rdx - tilt, 0.5 * ((s10 - s00) + (s11 - s01)) * rdy


@numba.njit(cache=True, inline="always")
def terrain_following_gradient(f, k, j, i, j1, i1, dx, dy, ct, ax, ay):
    """(∂x f, ∂y f, ∂z f) of a nodal field f at the centre of a lattice cell, by the chain rule
    of the terrain-following coordinates (∂x = ∂ξ − a_x ∂z, ∂y = ∂η − a_y ∂z)."""
    fz = 0.25 * ((f[k + 1, j, i] + f[k + 1, j, i1] + f[k + 1, j1, i] + f[k + 1, j1, i1])
                 - (f[k, j, i] + f[k, j, i1] + f[k, j1, i] + f[k, j1, i1])) / ct
    fx = 0.25 * ((f[k, j, i1] - f[k, j, i]) + (f[k, j1, i1] - f[k, j1, i])
                 + (f[k + 1, j, i1] - f[k + 1, j, i]) + (f[k + 1, j1, i1] - f[k + 1, j1, i])) / dx
    fy = 0.25 * ((f[k, j1, i] - f[k, j, i]) + (f[k, j1, i1] - f[k, j, i1])
                 + (f[k + 1, j1, i] - f[k + 1, j, i]) + (f[k + 1, j1, i1] - f[k + 1, j, i1])) / dy
    return fx - ax * fz, fy - ay * fz, fz


@numba.njit(cache=True, inline="always")
def basal_face(zeta, u, v, j, i, j1, i1, dx, dy, tilt):
    """A basal face's bed slopes (b_x with tilt, b_y), mean basal velocity (u_b, v_b, m/y) and
    its component along the bed normal's horizontal part t = u_b b_x + v_b b_y."""
    z00, z01, z10, z11 = zeta[0, j, i], zeta[0, j, i1], zeta[0, j1, i], zeta[0, j1, i1]
    bx = 0.5 * ((z01 - z00) + (z11 - z10)) / dx - tilt
    by = 0.5 * ((z10 - z00) + (z11 - z01)) / dy
    ub = 0.25 * (u[0, j, i] + u[0, j, i1] + u[0, j1, i] + u[0, j1, i1])
    vb = 0.25 * (v[0, j, i] + v[0, j, i1] + v[0, j1, i] + v[0, j1, i1])
    return bx, by, ub, vb, ub * bx + vb * by


@numba.njit(cache=True, inline="always")
def _cell_row(u, v, zeta, gu, gv, k, j, ncx, dx, dy, tilt, b_visc, p, rho_g, eps2):
    """Energy of the cells (k, j, ·) of one row of one layer; their gradient added to gu, gv
    (rows j and j + 1, wrapped)."""
    nz, ny, nx = u.shape
    area = dx * dy
    energy = 0.0
    half_p = 0.5 * p
    j1 = j + 1 if j + 1 < ny else 0
    rdx, rdy = 1.0 / dx, 1.0 / dy
    for i in range(ncx):
        i1 = i + 1 if i + 1 < nx else 0
        ct, ax, ay = cell_geometry(zeta, k, j, i, j1, i1, dx, dy, tilt)
        if ct <= 0.0:
            continue
        rct = 1.0 / ct
        sx, sy = surface_slope(zeta, j, i, j1, i1, rdx, rdy, tilt)

        ub00, ub01, ub10, ub11 = u[k, j, i], u[k, j, i1], u[k, j1, i], u[k, j1, i1]
        ut00, ut01, ut10, ut11 = u[k + 1, j, i], u[k + 1, j, i1], u[k + 1, j1, i], u[k + 1, j1, i1]
        vb00, vb01, vb10, vb11 = v[k, j, i], v[k, j, i1], v[k, j1, i], v[k, j1, i1]
        vt00, vt01, vt10, vt11 = v[k + 1, j, i], v[k + 1, j, i1], v[k + 1, j1, i], v[k + 1, j1, i1]

        uz = 0.25 * ((ut00 + ut01 + ut10 + ut11) - (ub00 + ub01 + ub10 + ub11)) * rct
        vz = 0.25 * ((vt00 + vt01 + vt10 + vt11) - (vb00 + vb01 + vb10 + vb11)) * rct
        ux = 0.25 * ((ub01 - ub00) + (ub11 - ub10) + (ut01 - ut00) + (ut11 - ut10)) * rdx - ax * uz
        vx = 0.25 * ((vb01 - vb00) + (vb11 - vb10) + (vt01 - vt00) + (vt11 - vt10)) * rdx - ax * vz
        uy = 0.25 * ((ub10 - ub00) + (ub11 - ub01) + (ut10 - ut00) + (ut11 - ut01)) * rdy - ay * uz
        vy = 0.25 * ((vb10 - vb00) + (vb11 - vb01) + (vt10 - vt00) + (vt11 - vt01)) * rdy - ay * vz
        uc = 0.125 * (ub00 + ub01 + ub10 + ub11 + ut00 + ut01 + ut10 + ut11)
        vc = 0.125 * (vb00 + vb01 + vb10 + vb11 + vt00 + vt01 + vt10 + vt11)

        dxy = 0.5 * (uy + vx)
        d2 = 2.0 * (ux * ux + vy * vy + ux * vy + dxy * dxy + 0.25 * (uz * uz + vz * vz)) + eps2
        vol = area * ct
        power = d2 ** (half_p - 1.0)  # one power per cell: |D|^p = |D|^(p−2)·|D|²
        energy += vol * (b_visc / p * power * d2 + rho_g * (sx * uc + sy * vc))

        w = vol * 0.5 * b_visc * power  # ∂E/∂|D|²
        g_ux = w * 2.0 * (2.0 * ux + vy)
        g_vy = w * 2.0 * (2.0 * vy + ux)
        g_uy = w * 2.0 * dxy
        g_vx = g_uy
        g_uz = w * uz - ax * g_ux - ay * g_uy
        g_vz = w * vz - ax * g_vx - ay * g_vy
        # per-corner weights: ±1/(4dx) along x, ±1/(4dy) along y, ±1/(4c_t) along z, 1/8 mean
        cxu, cyu, czu, c0u = 0.25 * g_ux * rdx, 0.25 * g_uy * rdy, 0.25 * g_uz * rct, 0.125 * vol * rho_g * sx
        cxv, cyv, czv, c0v = 0.25 * g_vx * rdx, 0.25 * g_vy * rdy, 0.25 * g_vz * rct, 0.125 * vol * rho_g * sy
        for c in range(2):
            kk = k + c
            sz = 2 * c - 1
            gu[kk, j, i] += c0u - cxu - cyu + sz * czu
            gu[kk, j, i1] += c0u + cxu - cyu + sz * czu
            gu[kk, j1, i] += c0u - cxu + cyu + sz * czu
            gu[kk, j1, i1] += c0u + cxu + cyu + sz * czu
            gv[kk, j, i] += c0v - cxv - cyv + sz * czv
            gv[kk, j, i1] += c0v + cxv - cyv + sz * czv
            gv[kk, j1, i] += c0v - cxv + cyv + sz * czv
            gv[kk, j1, i1] += c0v + cxv + cyv + sz * czv
    return energy


@numba.njit(cache=True, inline="always")
def _sliding(u, v, zeta, c_face, gu, gv, ncy, ncx, dx, dy, tilt, sigma, ureg2):
    """Energy of the basal faces; their gradient added to gu, gv (level 0)."""
    nz, ny, nx = u.shape
    area = dx * dy
    energy = 0.0
    half_s = 0.5 * sigma
    for j in range(ncy):
        j1 = j + 1 if j + 1 < ny else 0
        for i in range(ncx):
            cf = c_face[j, i]
            if cf <= 0.0:
                continue
            i1 = i + 1 if i + 1 < nx else 0
            bx, by, ub, vb, t = basal_face(zeta, u, v, j, i, j1, i1, dx, dy, tilt)
            m2 = ub * ub + vb * vb + t * t + ureg2
            face = area * math.sqrt(1.0 + bx * bx + by * by)  # the bed's area dS, not its plan view
            power = m2 ** (half_s - 1.0)
            energy += face * cf / sigma * power * m2
            ws = face * cf * 0.5 * power  # ∂E/∂|u_b|_M²
            gub = 0.25 * ws * 2.0 * (ub + t * bx)
            gvb = 0.25 * ws * 2.0 * (vb + t * by)
            gu[0, j, i] += gub
            gu[0, j, i1] += gub
            gu[0, j1, i] += gub
            gu[0, j1, i1] += gub
            gv[0, j, i] += gvb
            gv[0, j, i1] += gvb
            gv[0, j1, i] += gvb
            gv[0, j1, i1] += gvb
    return energy


@numba.njit(cache=True)
def energy_gradient(u, v, zeta, c_face, dx, dy, tilt, b_visc, p, sigma, rho_g, eps2, ureg2, periodic, gu, gv):
    """Blatter–Pattyn energy E (Pa·m³/y); its gradient with respect to every node velocity
    written into gu, gv.

    Args:
        u, v: float64[N+1, ny, nx] velocities along x and y (m/y).
        zeta: float64[N+1, ny, nx] node elevations without the background tilt (m).
        c_face: float64[ncy, ncx] sliding coefficient C of each basal face (Pa·(y/m)^(σ−1)),
            0 where there is no sliding friction (no ice, or a frozen face whose nodes are
            held at zero).
        dx, dy: cell sizes (m).
        tilt: tan of the background slope along +x.
        b_visc: B of 001 Eq. 4 (Pa·y^(1/n)) for the Frobenius norm |D|.
        p: 1 + 1/n; sigma: sliding exponent σ; rho_g: ρ·g (Pa/m).
        eps2: ε² (1/y²); ureg2: u_ε² (m²/y²).
        periodic: wrap the lattice around both axes.
        gu, gv: float64[N+1, ny, nx], overwritten with ∂E/∂u, ∂E/∂v (Pa·m³/y per m/y).

    Returns:
        E.

    Serial; ``energy_gradient_parallel`` gives the same numbers on threads.
    """
    nz, ny, nx = u.shape
    ncx = nx if periodic else nx - 1
    ncy = ny if periodic else ny - 1
    gu[:] = 0.0
    gv[:] = 0.0
    rows = np.zeros(ncy)
    paired = ncy - 1 if (periodic and ncy % 2 == 1) else ncy
    for parity in range(2):  # the order of ``energy_gradient_parallel``
        for j in range(parity, paired, 2):
            for k in range(nz - 1):
                rows[j] += _cell_row(u, v, zeta, gu, gv, k, j, ncx, dx, dy, tilt, b_visc, p, rho_g, eps2)
    for j in range(paired, ncy):
        for k in range(nz - 1):
            rows[j] += _cell_row(u, v, zeta, gu, gv, k, j, ncx, dx, dy, tilt, b_visc, p, rho_g, eps2)
    energy = 0.0
    for j in range(ncy):
        energy += rows[j]
    energy += _sliding(u, v, zeta, c_face, gu, gv, ncy, ncx, dx, dy, tilt, sigma, ureg2)
    return energy


@numba.njit(cache=True, parallel=True)
def energy_gradient_parallel(u, v, zeta, c_face, dx, dy, tilt, b_visc, p, sigma, rho_g, eps2, ureg2,
                             periodic, gu, gv):
    """``energy_gradient`` on threads, with the same result whatever their number: the rows of
    cells are done even rows first, then odd ones (a row writes the node rows j and j + 1 only,
    so rows of one parity never write the same node), each row by one thread in a fixed order;
    the row energies are added up in row order. A periodic lattice with an odd number of rows
    has its last row (which writes row 0) done alone at the end."""
    nz, ny, nx = u.shape
    ncx = nx if periodic else nx - 1
    ncy = ny if periodic else ny - 1
    for j in numba.prange(ny):
        gu[:, j] = 0.0
        gv[:, j] = 0.0
    rows = np.zeros(ncy)
    paired = ncy - 1 if (periodic and ncy % 2 == 1) else ncy
    for parity in range(2):
        for half in numba.prange((paired - parity + 1) // 2):
            j = 2 * half + parity
            for k in range(nz - 1):
                rows[j] += _cell_row(u, v, zeta, gu, gv, k, j, ncx, dx, dy, tilt, b_visc, p, rho_g, eps2)
    for j in range(paired, ncy):
        for k in range(nz - 1):
            rows[j] += _cell_row(u, v, zeta, gu, gv, k, j, ncx, dx, dy, tilt, b_visc, p, rho_g, eps2)
    energy = 0.0
    for j in range(ncy):
        energy += rows[j]
    energy += _sliding(u, v, zeta, c_face, gu, gv, ncy, ncx, dx, dy, tilt, sigma, ureg2)
    return energy


#: Lattices of at least this many nodes have their energy and gradient computed on threads.
PARALLEL_MIN_NODES = 100_000


@numba.njit(cache=True)
def expand_into(x, dof, u, v):
    """Write the node velocities (u, v), float64[N+1, ny, nx] each, of the unknowns
    x = [u_dof, v_dof] (m/y); nodes with dof −1 are held at zero."""
    n = x.size // 2
    uf = u.reshape(dof.size)
    vf = v.reshape(dof.size)
    df = dof.reshape(dof.size)
    for idx in range(df.size):
        d = df[idx]
        if d >= 0:
            uf[idx] = x[d]
            vf[idx] = x[n + d]
        else:
            uf[idx] = 0.0
            vf[idx] = 0.0


@numba.njit(cache=True)
def expand(x, dof):
    """Node velocities (u, v) of the unknowns x (``expand_into``), in new arrays."""
    u = np.empty(dof.shape)
    v = np.empty(dof.shape)
    expand_into(x, dof, u, v)
    return u, v


@numba.njit(cache=True)
def restrict(gu, gv, dof, n):
    """Gradient with respect to the unknowns: the sum of the node gradients sharing each one."""
    g = np.zeros(2 * n)
    guf = gu.reshape(dof.size)
    gvf = gv.reshape(dof.size)
    df = dof.reshape(dof.size)
    for idx in range(df.size):
        d = df[idx]
        if d >= 0:
            g[d] += guf[idx]
            g[n + d] += gvf[idx]
    return g


def workspace(dof):
    """Scratch of ``objective`` for the lattice of ``dof``: four float64[N+1, ny, nx] arrays (u, v
    and their gradients). Kept from one evaluation to the next, it spares each evaluation the
    first touch of four new arrays of the lattice's size: 33 instead of 48 ms at 256² × 10 and
    138 instead of 180 ms at 512² × 10 (one thread). Four arrays, not one block of four: a
    float64[4, N+1, ny, nx] block took 236 ms at 512²."""
    return tuple(np.empty(dof.shape) for _ in range(4))


@numba.njit(cache=True)
def objective(x, dof, zeta, c_face, dx, dy, tilt, b_visc, p, sigma, rho_g, eps2, ureg2, periodic, work):
    """Energy (Pa·m³/y) and its gradient with respect to the unknowns x = [u_dof, v_dof];
    ``work`` (``workspace``) is overwritten."""
    u, v, gu, gv = work
    expand_into(x, dof, u, v)
    if u.size >= PARALLEL_MIN_NODES:
        energy = energy_gradient_parallel(u, v, zeta, c_face, dx, dy, tilt, b_visc, p, sigma, rho_g, eps2,
                                          ureg2, periodic, gu, gv)
    else:
        energy = energy_gradient(u, v, zeta, c_face, dx, dy, tilt, b_visc, p, sigma, rho_g, eps2, ureg2,
                                 periodic, gu, gv)
    return energy, restrict(gu, gv, dof, x.size // 2)


@numba.njit(cache=True)
def driving_force(dof, zeta, dx, dy, tilt, rho_g, periodic, n):
    """∇E(0) with respect to the unknowns (float64[2n]): the gravitational driving term
    ρg·V·∇s/8 of every cell at its eight corners, the only part of the gradient that is not
    zero at u = 0 (the viscous and sliding terms vanish there). The same numbers as
    ``objective(0, …)[1]`` without its powers."""
    nz, ny, nx = zeta.shape
    ncx = nx if periodic else nx - 1
    ncy = ny if periodic else ny - 1
    gu = np.zeros(zeta.shape)
    gv = np.zeros(zeta.shape)
    for k in range(nz - 1):
        for j in range(ncy):
            j1 = j + 1 if j + 1 < ny else 0
            for i in range(ncx):
                i1 = i + 1 if i + 1 < nx else 0
                ct, ax, ay = cell_geometry(zeta, k, j, i, j1, i1, dx, dy, tilt)
                if ct <= 0.0:
                    continue
                sx, sy = surface_slope(zeta, j, i, j1, i1, 1.0 / dx, 1.0 / dy, tilt)
                vol = dx * dy * ct
                c0u, c0v = vol * rho_g * sx / 8, vol * rho_g * sy / 8
                for kk in range(k, k + 2):
                    gu[kk, j, i] += c0u
                    gu[kk, j, i1] += c0u
                    gu[kk, j1, i] += c0u
                    gu[kk, j1, i1] += c0u
                    gv[kk, j, i] += c0v
                    gv[kk, j, i1] += c0v
                    gv[kk, j1, i] += c0v
                    gv[kk, j1, i1] += c0v
    return restrict(gu, gv, dof, n)


@numba.njit(cache=True)
def picard_columns(x, dof, zeta, c_face, dx, dy, tilt, b_visc, p, sigma, eps2, ureg2, periodic):
    """The Picard (frozen-viscosity) Hessian of E restricted to each lattice column: the
    preconditioner of the minimisation (a vertical-line relaxation; thin lattice cells couple
    the levels of a column far more strongly than neighbouring columns).

    A cell couples each u unknown of corners a, b through w·(4α_x,a α_x,b + α_y,a α_y,b +
    α_z,a α_z,b) (x ↔ y for v), with w = ∂E/∂|D|² at the current velocities and α_x, α_y, α_z
    the corner weights in ∂x u, ∂y u, ∂z u (module docstring); only pairs in one column (the
    corner below and above, or one corner with itself) are kept. Each basal face adds
    w_s·2(1 + ∂x b²)/16 (w_s = ∂E/∂|u_b|_M²) to its corners' diagonal. Collapsed levels that
    share an unknown add their coupling to its diagonal. ``eps2`` and ``ureg2`` here are
    floors of |D|² and |u_b|_M² (they bound w and w_s).

    Returns:
        (diag, upper), float64[2n] each over the unknowns x = [u_dof, v_dof]: the diagonal (the
        largest one where no cell touches an unknown), and the coupling of each unknown with
        the next one up its column (0 at the top).
    """
    u, v = expand(x, dof)
    nz, ny, nx = u.shape
    n = x.size // 2
    ncx = nx if periodic else nx - 1
    ncy = ny if periodic else ny - 1
    diag = np.zeros(2 * n)
    upper = np.zeros(2 * n)
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


#: Vectors of at least this many unknowns have L-BFGS's passes (``dot``, ``_add_scaled_dot``,
#: ``new_pair``) and the column solves run on threads.
PARALLEL_MIN_UNKNOWNS = 200_000
#: Entries per block of those passes: each block's partial sum is taken alone and the blocks are
#: added in their order, on one thread or many, so the bits do not depend on the thread count.
BLOCK = 16_384


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


@numba.njit(cache=True, inline="always")
def _block_dot(a, b, lo, hi):
    """aᵀb over [lo, hi) in four interleaved partial sums (independent, so the loop runs at the
    memory's speed, not the adder's)."""
    s0 = s1 = s2 = s3 = 0.0
    end = hi - (hi - lo) % 4
    for i in range(lo, end, 4):
        s0 += a[i] * b[i]
        s1 += a[i + 1] * b[i + 1]
        s2 += a[i + 2] * b[i + 2]
        s3 += a[i + 3] * b[i + 3]
    for i in range(end, hi):
        s0 += a[i] * b[i]
    return (s0 + s1) + (s2 + s3)


@numba.njit(cache=True, inline="always")
def _block_add_scaled_dot(y, alpha, x, w, lo, hi):
    """y += α·x over [lo, hi), then wᵀy there (``_block_dot``'s order), in one pass."""
    s0 = s1 = s2 = s3 = 0.0
    end = hi - (hi - lo) % 4
    for i in range(lo, end, 4):
        y[i] += alpha * x[i]
        y[i + 1] += alpha * x[i + 1]
        y[i + 2] += alpha * x[i + 2]
        y[i + 3] += alpha * x[i + 3]
        s0 += w[i] * y[i]
        s1 += w[i + 1] * y[i + 1]
        s2 += w[i + 2] * y[i + 2]
        s3 += w[i + 3] * y[i + 3]
    for i in range(end, hi):
        y[i] += alpha * x[i]
        s0 += w[i] * y[i]
    return (s0 + s1) + (s2 + s3)


@numba.njit(cache=True, inline="always")
def _block_pair(x_new, x, g_new, g, s, y, lo, hi):
    """s = x_new − x and y = g_new − g over [lo, hi), then sᵀy there (``_block_dot``'s order)."""
    for i in range(lo, hi):
        s[i] = x_new[i] - x[i]
        y[i] = g_new[i] - g[i]
    return _block_dot(s, y, lo, hi)


@numba.njit(cache=True, inline="always")
def _blocks(size):
    return (size + BLOCK - 1) // BLOCK


@numba.njit(cache=True, inline="always")
def _ordered_sum(partial):
    total = 0.0
    for b in range(partial.size):
        total += partial[b]
    return total


@numba.njit(cache=True, parallel=True)
def _dot_threads(a, b):
    partial = np.empty(_blocks(a.size))
    for k in numba.prange(partial.size):
        partial[k] = _block_dot(a, b, k * BLOCK, min((k + 1) * BLOCK, a.size))
    return _ordered_sum(partial)


@numba.njit(cache=True)
def dot(a, b):
    """aᵀb: block partial sums (BLOCK) added in order, on threads from PARALLEL_MIN_UNKNOWNS
    entries, the same bits either way."""
    if a.size >= PARALLEL_MIN_UNKNOWNS:
        return _dot_threads(a, b)
    total = 0.0
    for k in range(_blocks(a.size)):
        total += _block_dot(a, b, k * BLOCK, min((k + 1) * BLOCK, a.size))
    return total


@numba.njit(cache=True, parallel=True)
def _add_scaled_dot_threads(y, alpha, x, w):
    partial = np.empty(_blocks(y.size))
    for k in numba.prange(partial.size):
        partial[k] = _block_add_scaled_dot(y, alpha, x, w, k * BLOCK, min((k + 1) * BLOCK, y.size))
    return _ordered_sum(partial)


@numba.njit(cache=True)
def _add_scaled_dot(y, alpha, x, w):
    """y += α·x in place, and wᵀy of the updated y (``dot``'s order) in the same pass."""
    if y.size >= PARALLEL_MIN_UNKNOWNS:
        return _add_scaled_dot_threads(y, alpha, x, w)
    total = 0.0
    for k in range(_blocks(y.size)):
        total += _block_add_scaled_dot(y, alpha, x, w, k * BLOCK, min((k + 1) * BLOCK, y.size))
    return total


@numba.njit(cache=True, parallel=True)
def _new_pair_threads(x_new, x, g_new, g, s, y):
    partial = np.empty(_blocks(x.size))
    for k in numba.prange(partial.size):
        partial[k] = _block_pair(x_new, x, g_new, g, s, y, k * BLOCK, min((k + 1) * BLOCK, x.size))
    return _ordered_sum(partial)


@numba.njit(cache=True)
def new_pair(x_new, x, g_new, g, s, y):
    """The L-BFGS pair of a step: s = x_new − x and y = g_new − g written in place, and sᵀy
    (``dot``'s order), in one pass."""
    if x.size >= PARALLEL_MIN_UNKNOWNS:
        return _new_pair_threads(x_new, x, g_new, g, s, y)
    total = 0.0
    for k in range(_blocks(x.size)):
        total += _block_pair(x_new, x, g_new, g, s, y, k * BLOCK, min((k + 1) * BLOCK, x.size))
    return total


@numba.njit(cache=True)
def lbfgs_direction(g, s_hist, y_hist, rho, count, newest, inv, ratio, upper, chains, out):
    """The L-BFGS step −H·g by the two-loop recursion (Nocedal & Wright, Algorithm 7.4), with
    the initial inverse Hessian γ·T⁻¹: T the column preconditioner (``picard_columns``,
    factorised by ``column_factor`` into inv, ratio) and γ = sᵀy / yᵀT⁻¹y of the newest pair.

    Args:
        g: float64[2n] gradient.
        s_hist, y_hist: float64[m, 2n] ring buffers of the last ``count`` steps s and gradient
            changes y, the newest in row ``newest``; rho: float64[m], 1 / sᵀy of each row.
        inv, ratio, upper, chains: the factorised preconditioner; out: float64[2n] scratch.
    """
    m = s_hist.shape[0]
    q = g.copy()
    alphas = np.zeros(m)
    curvature = 0.0
    # each pass updates q and takes the next pair's dot product with it (Algorithm 7.4's loops,
    # the dot of one iteration fused with the update of the one before)
    product = dot(s_hist[newest], q) if count > 0 else 0.0
    for back in range(count):
        row = (newest - back) % m
        alphas[row] = rho[row] * product
        following = s_hist[(row - 1) % m] if back + 1 < count else q
        product = _add_scaled_dot(q, -alphas[row], y_hist[row], following)
    if count > 0:
        column_solve_factored(inv, ratio, upper, chains, y_hist[newest], out)
        curvature = rho[newest] * dot(y_hist[newest], out)
    column_solve_factored(inv, ratio, upper, chains, q, out)
    scale = 1.0 / curvature if count > 0 and curvature > 0.0 else 1.0
    first = (newest - count + 1) % m
    for i in range(q.size):
        q[i] = scale * out[i]
    product = dot(y_hist[first], q) if count > 0 else 0.0
    for forward in range(count):
        row = (newest - count + 1 + forward) % m
        following = y_hist[(row + 1) % m] if forward + 1 < count else q
        product = _add_scaled_dot(q, alphas[row] - rho[row] * product, s_hist[row], following)
    for i in range(q.size):
        q[i] = -q[i]
    return q


# --- horizontal coarse-grid correction (``blatter``'s multigrid) --------------------------------------
#
# A coarse lattice keeps every ``fy``-th row and ``fx``-th column of nodes (f = 1 or 2 per axis) and
# the same levels k. Prolongation P: bilinear interpolation of the coarse node values along each
# coarsened axis (a fine node between two coarse nodes takes their mean; past the last coarse node of
# an open axis, its value), level by level. A fine unknown takes the value interpolated at its lowest
# node (the node it is stored at; collapsed nodes above share it). Restriction of a gradient: Pᵀ.


@numba.njit(cache=True, inline="always")
def _weights(i, f, nc, periodic):
    """Coarse neighbours (i0, i1) and weights (w0, w1) of fine index i along an axis coarsened by f
    (1 or 2) to nc coarse nodes (w1 = 0 when there is one)."""
    if f == 1:
        return i, i, 1.0, 0.0
    i0 = i // 2
    if i - 2 * i0 == 0:
        return i0, i0, 1.0, 0.0
    i1 = i0 + 1
    if i1 >= nc:
        if periodic:
            return i0, 0, 0.5, 0.5
        return i0, i0, 1.0, 0.0
    return i0, i1, 0.5, 0.5


@numba.njit(cache=True)
def transfer_entries(dof_f, dof_c, fy, fx, periodic):
    """The bilinear prolongation P as entries (fine unknown, coarse unknown, weight), int64[E],
    int64[E], float64[E], in the order of the fine nodes: P·y and Pᵀ·g both read them."""
    nz, ny, nx = dof_f.shape
    ncy, ncx = dof_c.shape[1], dof_c.shape[2]
    fine = np.empty(4 * dof_f.size, dtype=np.int64)
    coarse = np.empty(4 * dof_f.size, dtype=np.int64)
    weight = np.empty(4 * dof_f.size)
    e = 0
    for k in range(nz):
        for j in range(ny):
            j0, j1, wy0, wy1 = _weights(j, fy, ncy, periodic)
            for i in range(nx):
                d = dof_f[k, j, i]
                if d < 0 or (k > 0 and dof_f[k - 1, j, i] == d):
                    continue
                i0, i1, wx0, wx1 = _weights(i, fx, ncx, periodic)
                for b in range(2):
                    jj, wy = (j1, wy1) if b else (j0, wy0)
                    if wy == 0.0:
                        continue
                    for a in range(2):
                        ii, wx = (i1, wx1) if a else (i0, wx0)
                        if wx == 0.0:
                            continue
                        c = dof_c[k, jj, ii]
                        if c >= 0:
                            fine[e], coarse[e], weight[e] = d, c, wy * wx
                            e += 1
    return fine[:e], coarse[:e], weight[:e]


@numba.njit(cache=True)
def prolong(y, entries, n_f):
    """Fine unknowns (float64[2 n_f]) interpolated from the coarse unknowns y by P, given as
    ``transfer_entries``."""
    fine, coarse, weight = entries
    n_c = y.size // 2
    x = np.zeros(2 * n_f)
    for e in range(fine.size):
        x[fine[e]] += weight[e] * y[coarse[e]]
        x[n_f + fine[e]] += weight[e] * y[n_c + coarse[e]]
    return x


@numba.njit(cache=True)
def restrict_gradient(g, entries, n_c):
    """Pᵀ·g (P as ``transfer_entries``): the gradient with respect to the coarse unknowns of
    E(P·y), float64[2 n_c]."""
    fine, coarse, weight = entries
    n_f = g.size // 2
    out = np.zeros(2 * n_c)
    for e in range(fine.size):
        out[coarse[e]] += weight[e] * g[fine[e]]
        out[n_c + coarse[e]] += weight[e] * g[n_f + fine[e]]
    return out


@numba.njit(cache=True)
def inject(x, dof_f, dof_c, n_c, fy, fx):
    """Coarse unknowns (float64[2 n_c]) taking the fine values at the coarse nodes (0 where the fine
    node has none)."""
    nz, ncy, ncx = dof_c.shape
    n_f = x.size // 2
    y = np.zeros(2 * n_c)
    for k in range(nz):
        for j in range(ncy):
            for i in range(ncx):
                c = dof_c[k, j, i]
                if c < 0 or (k > 0 and dof_c[k - 1, j, i] == c):
                    continue
                d = dof_f[k, j * fy, i * fx]
                if d >= 0:
                    y[c] = x[d]
                    y[n_c + c] = x[n_f + d]
    return y
