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

Unknowns: ``objective`` and ``driving_force`` take the velocities as the vector x = [u_dof,
v_dof] (m/y) of the lattice's degrees of freedom (``lattice.dof_map``: an int64[N+1, ny, nx]
table ``dof``, −1 on nodes held at zero, collapsed levels sharing one unknown); ``expand``
writes them onto the nodes and ``restrict`` sums the node gradients back onto them.
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
