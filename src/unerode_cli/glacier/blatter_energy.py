"""Numba kernels of the Blatter–Pattyn energy (001 Eq. 7) and its analytic gradient.

Discretisation (001 §4.2 and Appendix A): horizontal velocities (u, v) (m/y) live on the nodes
of the terrain-following lattice ζ[k, j, i] (``lattice``); every lattice cell, a hexahedron
with vertical edges between columns (i, i+1) × (j, j+1) and levels (k, k+1), is one trilinear
(isoparametric) finite element integrated at four points: the 2 × 2 Gauss points
ξ, η = ±1/√3 of its plan at mid-height. At a point with bilinear weights w (over the four
corner columns), with the column means m = (f_k + f_k+1)/2 and differences d = f_k+1 − f_k:

    c_t   = Σ w·d(ζ)                             thickness of the cell at the point (m)
    dV    = dx·dy·c_t / 4                        the point's share of the volume (m³)
    u_q   = Σ w·m(u)                             velocity at the point
    ∂z u  = Σ w·d(u) / c_t
    ∂x u  = ∂ξ[Σ w·m(u)]/dx − a_x·∂z u,  a_x = ∂ξ[Σ w·m(ζ)]/dx   (∂y alike)

i.e. the exact gradient of the element at the point by the chain rule of the terrain-following
coordinates. 001 Appendix A evaluates each cell at its centre alone (one point, the averaging
operators a_x a_y a_z); that one-point rule leaves the checkerboard ("hourglass") patterns of
the velocity, e.g. (−1)^(i+j) over the nodes, without any strain rate, so they cost no energy:
E then has many minimisers, and the nearly checkerboard patterns, which cost almost none,
are the ones an iterative solver reduces slowest. Four points see every pattern but a uniform
velocity. (001 Eq. 9–10 as printed do not vanish for a uniform velocity, so they are not used
verbatim.)

Energy (001 Eq. 7), velocities in m/y and stresses in Pa, so in Pa·m³/y:

    E = Σ_points dV·[ (B/p)·(|D|² + ε²)^(p/2) + ρg·(∂x s·u_q + ∂y s·v_q) ]
      + Σ_basal points dx·dy/4·√(1 + |∇b|²)·(C/σ)·(|u_b|_M² + u_ε²)^(σ/2)

with the first-order strain-rate tensor D (001 §4.1; D_zz = −D_xx − D_yy)

    |D|² = D:D = 2·(D_xx² + D_yy² + D_xx·D_yy + D_xy² + D_xz² + D_yz²),
    D_xx = ∂x u, D_yy = ∂y v, D_xy = (∂y u + ∂x v)/2, D_xz = ∂z u/2, D_yz = ∂z v/2,

∂x s, ∂y s the gradient of the ice surface (the lattice's top level) at the point, u_b the
bilinear basal velocity at the bed's own Gauss points (2 × 2 a basal face) and the bed-
tangential norm |u_b|_M² = u_b² + v_b² + (u_b·∂x b + v_b·∂y b)². ε (1/y) and u_ε (m/y) are small
regularisations that make the energy twice differentiable at zero strain rate and zero sliding.
The sliding term is integrated over the area of the bed (001 Eq. 7's dS over Γ), dx·dy·√(1 +
|∇b|²) per face (summed over its points), not over its plan view dx·dy: on an inclined slab this
gives the exact Weertman speed |u_b| = (ρgH·sin α·cos α / C)^(1/(σ−1)) along the bed (H
vertical), where the plan-view area would slide 1/cos²α faster for σ = 3/2 (×1.33 on 30°, ×2.4
on 50°: thin ice on steep walls, where real DEMs have it). ``tilt`` = tan(background slope) is a
uniform inclination along +x: the true elevations are ζ − x·tilt, which enters ∂x ζ, ∂x s and ∂x
b.

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


#: In-plane Gauss points of a lattice cell, ξ = η = ±1/√3 on [−1, 1] (2 × 2 Gauss–Legendre).
GAUSS = 1.0 / math.sqrt(3.0)


@numba.njit(cache=True, inline="always")
def _power(x, e):
    """x**e for x > 0, by cube or square roots for Glen's n = 3 (e = −1/3) and σ = 3/2
    (e = −1/4), several times cheaper than the general power."""
    if e == GLEN3_EXPONENT:
        return 1.0 / np.cbrt(x)
    if e == -0.25:
        return 1.0 / math.sqrt(math.sqrt(x))
    return x ** e


#: −1/3, the exponent p/2 − 1 of Glen's n = 3 (p = 4/3) as the solver computes it.
GLEN3_EXPONENT = 0.5 * (1.0 + 1.0 / 3.0) - 1.0


@numba.njit(cache=True, inline="always")
def gauss_weights(q):
    """Bilinear weights of the in-plane Gauss point q (0..3) of a cell: along x (w_x0, w_x1)
    and y (w_y0, w_y1), each pair summing to 1."""
    xi = GAUSS if q & 1 else -GAUSS
    eta = GAUSS if q & 2 else -GAUSS
    wx1 = 0.5 * (1.0 + xi)
    wy1 = 0.5 * (1.0 + eta)
    return 1.0 - wx1, wx1, 1.0 - wy1, wy1


@numba.njit(cache=True, inline="always")
def _add_to_columns(g, k, j, i, j1, i1, m00, m01, m10, m11, d00, d01, d10, d11):
    """Add the gradient with respect to the four corner columns' mid-height means (m_a) and
    differences (d_a) of a cell to its nodes: ½·m_a − d_a below (level k), ½·m_a + d_a above."""
    g[k, j, i] += 0.5 * m00 - d00
    g[k + 1, j, i] += 0.5 * m00 + d00
    g[k, j, i1] += 0.5 * m01 - d01
    g[k + 1, j, i1] += 0.5 * m01 + d01
    g[k, j1, i] += 0.5 * m10 - d10
    g[k + 1, j1, i] += 0.5 * m10 + d10
    g[k, j1, i1] += 0.5 * m11 - d11
    g[k + 1, j1, i1] += 0.5 * m11 + d11


@numba.njit(cache=True, inline="always")
def _cell_row(u, v, zeta, gu, gv, k, j, ncx, dx, dy, tilt, b_visc, p, rho_g, eps2):
    """Energy of the cells (k, j, ·) of one row of one layer, four in-plane Gauss points a
    cell at mid-height; their gradient added to gu, gv (rows j and j + 1, wrapped).

    Each corner column (a = 00, 01, 10, 11 for (j, i), (j, i1), (j1, i), (j1, i1)) enters
    through its mid-height mean m_a = (f_bottom + f_top)/2 and its difference
    d_a = f_top − f_bottom; the gradient is accumulated on (m_a, d_a) and passed to the
    nodes as ∂/∂f_bottom = ½∂/∂m − ∂/∂d, ∂/∂f_top = ½∂/∂m + ∂/∂d.

    Kept whole: a cell's four points add into sixteen scalar accumulators held in registers;
    parts of it would pass them back and forth as tuples inside the threaded row loop."""
    nz, ny, nx = u.shape
    area = dx * dy
    energy = 0.0
    half_p = 0.5 * p
    top = nz - 1
    j1 = j + 1 if j + 1 < ny else 0
    rdx, rdy = 1.0 / dx, 1.0 / dy
    for i in range(ncx):
        i1 = i + 1 if i + 1 < nx else 0
        h00 = zeta[k + 1, j, i] - zeta[k, j, i]
        h01 = zeta[k + 1, j, i1] - zeta[k, j, i1]
        h10 = zeta[k + 1, j1, i] - zeta[k, j1, i]
        h11 = zeta[k + 1, j1, i1] - zeta[k, j1, i1]
        if h00 + h01 + h10 + h11 <= 0.0:
            continue
        z00 = 0.5 * (zeta[k + 1, j, i] + zeta[k, j, i])
        z01 = 0.5 * (zeta[k + 1, j, i1] + zeta[k, j, i1])
        z10 = 0.5 * (zeta[k + 1, j1, i] + zeta[k, j1, i])
        z11 = 0.5 * (zeta[k + 1, j1, i1] + zeta[k, j1, i1])
        s00, s01, s10, s11 = zeta[top, j, i], zeta[top, j, i1], zeta[top, j1, i], zeta[top, j1, i1]
        mu00, du00 = 0.5 * (u[k, j, i] + u[k + 1, j, i]), u[k + 1, j, i] - u[k, j, i]
        mu01, du01 = 0.5 * (u[k, j, i1] + u[k + 1, j, i1]), u[k + 1, j, i1] - u[k, j, i1]
        mu10, du10 = 0.5 * (u[k, j1, i] + u[k + 1, j1, i]), u[k + 1, j1, i] - u[k, j1, i]
        mu11, du11 = 0.5 * (u[k, j1, i1] + u[k + 1, j1, i1]), u[k + 1, j1, i1] - u[k, j1, i1]
        mv00, dv00 = 0.5 * (v[k, j, i] + v[k + 1, j, i]), v[k + 1, j, i] - v[k, j, i]
        mv01, dv01 = 0.5 * (v[k, j, i1] + v[k + 1, j, i1]), v[k + 1, j, i1] - v[k, j, i1]
        mv10, dv10 = 0.5 * (v[k, j1, i] + v[k + 1, j1, i]), v[k + 1, j1, i] - v[k, j1, i]
        mv11, dv11 = 0.5 * (v[k, j1, i1] + v[k + 1, j1, i1]), v[k + 1, j1, i1] - v[k, j1, i1]
        gmu00 = gmu01 = gmu10 = gmu11 = gdu00 = gdu01 = gdu10 = gdu11 = 0.0
        gmv00 = gmv01 = gmv10 = gmv11 = gdv00 = gdv01 = gdv10 = gdv11 = 0.0
        for q in range(4):
            wx0, wx1, wy0, wy1 = gauss_weights(q)
            n00, n01, n10, n11 = wy0 * wx0, wy0 * wx1, wy1 * wx0, wy1 * wx1
            ct = n00 * h00 + n01 * h01 + n10 * h10 + n11 * h11
            rct = 1.0 / ct
            ax = (wy0 * (z01 - z00) + wy1 * (z11 - z10)) * rdx - tilt
            ay = (wx0 * (z10 - z00) + wx1 * (z11 - z01)) * rdy
            sx = (wy0 * (s01 - s00) + wy1 * (s11 - s10)) * rdx - tilt
            sy = (wx0 * (s10 - s00) + wx1 * (s11 - s01)) * rdy
            uz = (n00 * du00 + n01 * du01 + n10 * du10 + n11 * du11) * rct
            vz = (n00 * dv00 + n01 * dv01 + n10 * dv10 + n11 * dv11) * rct
            ux = (wy0 * (mu01 - mu00) + wy1 * (mu11 - mu10)) * rdx - ax * uz
            vx = (wy0 * (mv01 - mv00) + wy1 * (mv11 - mv10)) * rdx - ax * vz
            uy = (wx0 * (mu10 - mu00) + wx1 * (mu11 - mu01)) * rdy - ay * uz
            vy = (wx0 * (mv10 - mv00) + wx1 * (mv11 - mv01)) * rdy - ay * vz
            uc = n00 * mu00 + n01 * mu01 + n10 * mu10 + n11 * mu11
            vc = n00 * mv00 + n01 * mv01 + n10 * mv10 + n11 * mv11

            dxy = 0.5 * (uy + vx)
            d2 = 2.0 * (ux * ux + vy * vy + ux * vy + dxy * dxy + 0.25 * (uz * uz + vz * vz)) + eps2
            vol = 0.25 * area * ct
            power = _power(d2, half_p - 1.0)  # |D|^p = |D|^(p−2)·|D|²
            energy += vol * (b_visc / p * power * d2 + rho_g * (sx * uc + sy * vc))

            w = vol * 0.5 * b_visc * power  # ∂E/∂|D|²
            g_ux = w * 2.0 * (2.0 * ux + vy)
            g_vy = w * 2.0 * (2.0 * vy + ux)
            g_uy = w * 2.0 * dxy
            g_vx = g_uy
            gzu = (w * uz - ax * g_ux - ay * g_uy) * rct
            gzv = (w * vz - ax * g_vx - ay * g_vy) * rct
            gxu, gyu, gcu = g_ux * rdx, g_uy * rdy, vol * rho_g * sx
            gxv, gyv, gcv = g_vx * rdx, g_vy * rdy, vol * rho_g * sy
            gmu00 += n00 * gcu - wy0 * gxu - wx0 * gyu
            gmu01 += n01 * gcu + wy0 * gxu - wx1 * gyu
            gmu10 += n10 * gcu - wy1 * gxu + wx0 * gyu
            gmu11 += n11 * gcu + wy1 * gxu + wx1 * gyu
            gmv00 += n00 * gcv - wy0 * gxv - wx0 * gyv
            gmv01 += n01 * gcv + wy0 * gxv - wx1 * gyv
            gmv10 += n10 * gcv - wy1 * gxv + wx0 * gyv
            gmv11 += n11 * gcv + wy1 * gxv + wx1 * gyv
            gdu00 += n00 * gzu
            gdu01 += n01 * gzu
            gdu10 += n10 * gzu
            gdu11 += n11 * gzu
            gdv00 += n00 * gzv
            gdv01 += n01 * gzv
            gdv10 += n10 * gzv
            gdv11 += n11 * gzv
        _add_to_columns(gu, k, j, i, j1, i1, gmu00, gmu01, gmu10, gmu11, gdu00, gdu01, gdu10, gdu11)
        _add_to_columns(gv, k, j, i, j1, i1, gmv00, gmv01, gmv10, gmv11, gdv00, gdv01, gdv10, gdv11)
    return energy


@numba.njit(cache=True, inline="always")
def _sliding(u, v, zeta, c_face, gu, gv, ncy, ncx, dx, dy, tilt, sigma, ureg2):
    """Energy of the basal faces, four Gauss points a face; their gradient added to gu, gv
    (level 0)."""
    nz, ny, nx = u.shape
    area = dx * dy
    energy = 0.0
    half_s = 0.5 * sigma
    rdx, rdy = 1.0 / dx, 1.0 / dy
    for j in range(ncy):
        j1 = j + 1 if j + 1 < ny else 0
        for i in range(ncx):
            cf = c_face[j, i]
            if cf <= 0.0:
                continue
            i1 = i + 1 if i + 1 < nx else 0
            z00, z01, z10, z11 = zeta[0, j, i], zeta[0, j, i1], zeta[0, j1, i], zeta[0, j1, i1]
            u00, u01, u10, u11 = u[0, j, i], u[0, j, i1], u[0, j1, i], u[0, j1, i1]
            v00, v01, v10, v11 = v[0, j, i], v[0, j, i1], v[0, j1, i], v[0, j1, i1]
            gu00 = gu01 = gu10 = gu11 = gv00 = gv01 = gv10 = gv11 = 0.0
            for q in range(4):
                wx0, wx1, wy0, wy1 = gauss_weights(q)
                n00, n01, n10, n11 = wy0 * wx0, wy0 * wx1, wy1 * wx0, wy1 * wx1
                bx = (wy0 * (z01 - z00) + wy1 * (z11 - z10)) * rdx - tilt
                by = (wx0 * (z10 - z00) + wx1 * (z11 - z01)) * rdy
                ub = n00 * u00 + n01 * u01 + n10 * u10 + n11 * u11
                vb = n00 * v00 + n01 * v01 + n10 * v10 + n11 * v11
                t = ub * bx + vb * by
                m2 = ub * ub + vb * vb + t * t + ureg2
                face = 0.25 * area * math.sqrt(1.0 + bx * bx + by * by)  # the bed's area dS
                power = _power(m2, half_s - 1.0)
                energy += face * cf / sigma * power * m2
                ws = face * cf * power  # 2·∂E/∂|u_b|_M²
                gub = ws * (ub + t * bx)
                gvb = ws * (vb + t * by)
                gu00 += n00 * gub
                gu01 += n01 * gub
                gu10 += n10 * gub
                gu11 += n11 * gub
                gv00 += n00 * gvb
                gv01 += n01 * gvb
                gv10 += n10 * gvb
                gv11 += n11 * gvb
            gu[0, j, i] += gu00
            gu[0, j, i1] += gu01
            gu[0, j1, i] += gu10
            gu[0, j1, i1] += gu11
            gv[0, j, i] += gv00
            gv[0, j, i1] += gv01
            gv[0, j1, i] += gv10
            gv[0, j1, i1] += gv11
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
    and their gradients), kept from one evaluation to the next so that an evaluation writes into
    memory already touched."""
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
    ρg·∇s·u of every cell at its four Gauss points, the only part of the gradient that is not
    zero at u = 0 (the viscous and sliding terms vanish there). The same numbers as
    ``objective(0, …)[1]`` without its powers."""
    nz, ny, nx = zeta.shape
    top = nz - 1
    ncx = nx if periodic else nx - 1
    ncy = ny if periodic else ny - 1
    gu = np.zeros(zeta.shape)
    gv = np.zeros(zeta.shape)
    area = dx * dy
    for k in range(nz - 1):
        for j in range(ncy):
            j1 = j + 1 if j + 1 < ny else 0
            for i in range(ncx):
                i1 = i + 1 if i + 1 < nx else 0
                h = (zeta[k + 1, j, i] - zeta[k, j, i], zeta[k + 1, j, i1] - zeta[k, j, i1],
                     zeta[k + 1, j1, i] - zeta[k, j1, i], zeta[k + 1, j1, i1] - zeta[k, j1, i1])
                if h[0] + h[1] + h[2] + h[3] <= 0.0:
                    continue
                s00, s01, s10, s11 = zeta[top, j, i], zeta[top, j, i1], zeta[top, j1, i], zeta[top, j1, i1]
                for q in range(4):
                    wx0, wx1, wy0, wy1 = gauss_weights(q)
                    nw = (wy0 * wx0, wy0 * wx1, wy1 * wx0, wy1 * wx1)
                    ct = nw[0] * h[0] + nw[1] * h[1] + nw[2] * h[2] + nw[3] * h[3]
                    sx = (wy0 * (s01 - s00) + wy1 * (s11 - s10)) / dx - tilt
                    sy = (wx0 * (s10 - s00) + wx1 * (s11 - s01)) / dy
                    cu, cv = 0.125 * area * ct * rho_g * sx, 0.125 * area * ct * rho_g * sy
                    for kk in range(k, k + 2):
                        gu[kk, j, i] += nw[0] * cu
                        gu[kk, j, i1] += nw[1] * cu
                        gu[kk, j1, i] += nw[2] * cu
                        gu[kk, j1, i1] += nw[3] * cu
                        gv[kk, j, i] += nw[0] * cv
                        gv[kk, j, i1] += nw[1] * cv
                        gv[kk, j1, i] += nw[2] * cv
                        gv[kk, j1, i1] += nw[3] * cv
    return restrict(gu, gv, dof, n)
