"""A compact single-thread MLS-MPM substep: the reference the project's stress solver is timed
against (``bench_sandstone``).

A plain implementation of MLS-MPM (Hu et al. 2018, the 88-line sketch lifted to 3D): quadratic
B-splines, APIC/MLS affine transfer, the corotated model τ = 2μ(F − R)Fᵀ + λJ(J − 1)I with R
from Newton's polar iteration R ← (R + R⁻ᵀ)/2 (the project's stopping rule: change < 1e-15 or 30
iterations), float64 throughout, gravity, a sticky ground (v = 0 on and below the domain's low z
face, no horizontal velocity on the level above, as the project's solver) and roller side walls.
Particles in array order on one thread; each node's contribution computed as written, w·(m v +
Q (x_i − x_p)) and w·v_i (x_i − x_p)ᵀ, over the whole grid: what one writes first, with
scalar locals as numba likes them, not made slow on purpose. On the same state it gives the
project's substep to round-off (positions within 1e-13 m after five substeps of the bench block).

Grid layout as the project's: node n along an axis sits at ``origin + (n − 1)·h``, ``cells + 3``
nodes per axis. Units: m, s, kg, Pa.
"""

from __future__ import annotations

import numba
import numpy as np

POLAR_TOLERANCE = 1e-15
POLAR_MAX_ITERATIONS = 30


@numba.njit(cache=True)
def corotated(f: np.ndarray, mu: float, lam: float):
    """Kirchhoff stress τ (row-major 9-tuple, Pa) of F (3 × 3), R by Newton's polar iteration."""
    r0, r1, r2 = f[0, 0], f[0, 1], f[0, 2]
    r3, r4, r5 = f[1, 0], f[1, 1], f[1, 2]
    r6, r7, r8 = f[2, 0], f[2, 1], f[2, 2]
    for _ in range(POLAR_MAX_ITERATIONS):
        c0, c1, c2 = r4 * r8 - r5 * r7, r5 * r6 - r3 * r8, r3 * r7 - r4 * r6
        c3, c4, c5 = r2 * r7 - r1 * r8, r0 * r8 - r2 * r6, r1 * r6 - r0 * r7
        c6, c7, c8 = r1 * r5 - r2 * r4, r2 * r3 - r0 * r5, r0 * r4 - r1 * r3
        det = r0 * c0 + r1 * c1 + r2 * c2
        n0, n1, n2 = 0.5 * (r0 + c0 / det), 0.5 * (r1 + c1 / det), 0.5 * (r2 + c2 / det)
        n3, n4, n5 = 0.5 * (r3 + c3 / det), 0.5 * (r4 + c4 / det), 0.5 * (r5 + c5 / det)
        n6, n7, n8 = 0.5 * (r6 + c6 / det), 0.5 * (r7 + c7 / det), 0.5 * (r8 + c8 / det)
        change = max(abs(n0 - r0), abs(n1 - r1), abs(n2 - r2), abs(n3 - r3), abs(n4 - r4), abs(n5 - r5),
                     abs(n6 - r6), abs(n7 - r7), abs(n8 - r8))
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = n0, n1, n2, n3, n4, n5, n6, n7, n8
        if change < POLAR_TOLERANCE:
            break
    j = (f[0, 0] * (f[1, 1] * f[2, 2] - f[1, 2] * f[2, 1]) - f[0, 1] * (f[1, 0] * f[2, 2] - f[1, 2] * f[2, 0])
         + f[0, 2] * (f[1, 0] * f[2, 1] - f[1, 1] * f[2, 0]))
    d = (f[0, 0] - r0, f[0, 1] - r1, f[0, 2] - r2, f[1, 0] - r3, f[1, 1] - r4, f[1, 2] - r5,
         f[2, 0] - r6, f[2, 1] - r7, f[2, 2] - r8)
    vol = lam * j * (j - 1.0)
    m = 2.0 * mu
    return (m * (d[0] * f[0, 0] + d[1] * f[0, 1] + d[2] * f[0, 2]) + vol,
            m * (d[0] * f[1, 0] + d[1] * f[1, 1] + d[2] * f[1, 2]),
            m * (d[0] * f[2, 0] + d[1] * f[2, 1] + d[2] * f[2, 2]),
            m * (d[3] * f[0, 0] + d[4] * f[0, 1] + d[5] * f[0, 2]),
            m * (d[3] * f[1, 0] + d[4] * f[1, 1] + d[5] * f[1, 2]) + vol,
            m * (d[3] * f[2, 0] + d[4] * f[2, 1] + d[5] * f[2, 2]),
            m * (d[6] * f[0, 0] + d[7] * f[0, 1] + d[8] * f[0, 2]),
            m * (d[6] * f[1, 0] + d[7] * f[1, 1] + d[8] * f[1, 2]),
            m * (d[6] * f[2, 0] + d[7] * f[2, 1] + d[8] * f[2, 2]) + vol)


@numba.njit(cache=True, inline="always")
def _stencil(x: float, origin: float, inv_h: float):
    """Base node (array index), offset fx ∈ [0.5, 1.5) and the three weights along one axis."""
    u = (x - origin) * inv_h
    base = int(np.floor(u - 0.5))
    fx = u - base
    return base + 1, fx, (0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2)


@numba.njit(cache=True)
def particles_to_grid(x, v, c, f, grid_m, grid_v, dt, h, origin, mass, volume, mu, lam) -> None:
    inv_h = 1.0 / h
    scale = -dt * volume * 4.0 * inv_h * inv_h
    for p in range(x.shape[0]):
        bx, fx, wx = _stencil(x[p, 0], origin[0], inv_h)
        by, fy, wy = _stencil(x[p, 1], origin[1], inv_h)
        bz, fz, wz = _stencil(x[p, 2], origin[2], inv_h)
        t0, t1, t2, t3, t4, t5, t6, t7, t8 = corotated(f[p], mu, lam)
        m = mass
        q0, q1, q2 = scale * t0 + m * c[p, 0, 0], scale * t1 + m * c[p, 0, 1], scale * t2 + m * c[p, 0, 2]
        q3, q4, q5 = scale * t3 + m * c[p, 1, 0], scale * t4 + m * c[p, 1, 1], scale * t5 + m * c[p, 1, 2]
        q6, q7, q8 = scale * t6 + m * c[p, 2, 0], scale * t7 + m * c[p, 2, 1], scale * t8 + m * c[p, 2, 2]
        mv0, mv1, mv2 = mass * v[p, 0], mass * v[p, 1], mass * v[p, 2]
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    weight = wx[i] * wy[j] * wz[k]
                    d0, d1, d2 = (i - fx) * h, (j - fy) * h, (k - fz) * h
                    grid_v[bx + i, by + j, bz + k, 0] += weight * (mv0 + q0 * d0 + q1 * d1 + q2 * d2)
                    grid_v[bx + i, by + j, bz + k, 1] += weight * (mv1 + q3 * d0 + q4 * d1 + q5 * d2)
                    grid_v[bx + i, by + j, bz + k, 2] += weight * (mv2 + q6 * d0 + q7 * d1 + q8 * d2)
                    grid_m[bx + i, by + j, bz + k] += weight * mass


@numba.njit(cache=True)
def update_grid(grid_m, grid_v, dt, gravity, damping) -> float:
    nx, ny, nz = grid_m.shape
    energy = total = 0.0
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                m = grid_m[i, j, k]
                if m <= 0.0:
                    continue
                for a in range(3):
                    grid_v[i, j, k, a] = grid_v[i, j, k, a] / m * (1.0 - damping)
                grid_v[i, j, k, 2] -= dt * gravity * (1.0 - damping)
                if k <= 1:
                    grid_v[i, j, k, :] = 0.0
                if k == 2:
                    grid_v[i, j, k, 0] = grid_v[i, j, k, 1] = 0.0
                if i <= 1 or i >= nx - 2:
                    grid_v[i, j, k, 0] = 0.0
                if j <= 1 or j >= ny - 2:
                    grid_v[i, j, k, 1] = 0.0
                energy += m * (grid_v[i, j, k, 0] ** 2 + grid_v[i, j, k, 1] ** 2 + grid_v[i, j, k, 2] ** 2)
                total += m
    return np.sqrt(energy / total) if total > 0.0 else 0.0


@numba.njit(cache=True)
def grid_to_particles(x, v, c, f, grid_v, dt, h, origin) -> None:
    inv_h = 1.0 / h
    for p in range(x.shape[0]):
        bx, fx, wx = _stencil(x[p, 0], origin[0], inv_h)
        by, fy, wy = _stencil(x[p, 1], origin[1], inv_h)
        bz, fz, wz = _stencil(x[p, 2], origin[2], inv_h)
        v0 = v1 = v2 = 0.0
        c00 = c01 = c02 = c10 = c11 = c12 = c20 = c21 = c22 = 0.0
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    weight = wx[i] * wy[j] * wz[k]
                    d0, d1, d2 = (i - fx) * h, (j - fy) * h, (k - fz) * h
                    g0, g1, g2 = grid_v[bx + i, by + j, bz + k, 0], grid_v[bx + i, by + j, bz + k, 1], \
                        grid_v[bx + i, by + j, bz + k, 2]
                    v0 += weight * g0
                    v1 += weight * g1
                    v2 += weight * g2
                    s = 4.0 * inv_h * inv_h * weight
                    c00 += s * g0 * d0
                    c01 += s * g0 * d1
                    c02 += s * g0 * d2
                    c10 += s * g1 * d0
                    c11 += s * g1 * d1
                    c12 += s * g1 * d2
                    c20 += s * g2 * d0
                    c21 += s * g2 * d1
                    c22 += s * g2 * d2
        v[p, 0], v[p, 1], v[p, 2] = v0, v1, v2
        c[p, 0, 0], c[p, 0, 1], c[p, 0, 2] = c00, c01, c02
        c[p, 1, 0], c[p, 1, 1], c[p, 1, 2] = c10, c11, c12
        c[p, 2, 0], c[p, 2, 1], c[p, 2, 2] = c20, c21, c22
        x[p, 0] += dt * v0
        x[p, 1] += dt * v1
        x[p, 2] += dt * v2
        for b in range(3):
            f0, f1, f2 = f[p, 0, b], f[p, 1, b], f[p, 2, b]
            f[p, 0, b] = f0 + dt * (c00 * f0 + c01 * f1 + c02 * f2)
            f[p, 1, b] = f1 + dt * (c10 * f0 + c11 * f1 + c12 * f2)
            f[p, 2, b] = f2 + dt * (c20 * f0 + c21 * f1 + c22 * f2)


@numba.njit(cache=True)
def substep(x, v, c, f, grid_m, grid_v, dt, h, origin, mass, volume, mu, lam, gravity, damping) -> float:
    """One MLS-MPM step of particles ``x`` (N, 3), ``v`` (N, 3), ``c`` (N, 3, 3), ``f`` (N, 3, 3)
    in place, on the grids ``grid_m`` (nx, ny, nz) and ``grid_v`` (nx, ny, nz, 3); returns the
    mass-weighted RMS node speed (m/s)."""
    grid_m[:] = 0.0
    grid_v[:] = 0.0
    particles_to_grid(x, v, c, f, grid_m, grid_v, dt, h, origin, mass, volume, mu, lam)
    speed = update_grid(grid_m, grid_v, dt, gravity, damping)
    grid_to_particles(x, v, c, f, grid_v, dt, h, origin)
    return speed


class Reference:
    """The sketch's state for particles at ``positions`` (N, 3) with deformation gradients
    ``deformation`` (N, 3, 3) (copied), on a grid of ``cells`` cells of ``h`` m from ``origin``."""

    def __init__(self, positions: np.ndarray, deformation: np.ndarray, cells: tuple[int, int, int], h: float,
                 origin: np.ndarray, mass: float, volume: float, mu: float, lam: float, dt: float):
        self.x = np.array(positions, dtype=np.float64)
        self.v = np.zeros_like(self.x)
        self.c = np.zeros((len(self.x), 3, 3))
        self.f = np.array(deformation, dtype=np.float64)
        nodes = tuple(n + 3 for n in cells)
        self.grid_m = np.zeros(nodes)
        self.grid_v = np.zeros((*nodes, 3))
        self.h, self.origin = h, np.asarray(origin, dtype=np.float64)
        self.mass, self.volume, self.mu, self.lam, self.dt = mass, volume, mu, lam, dt

    def substep(self, gravity: float, damping: float) -> float:
        """One substep on one thread (nothing here is parallel); returns the RMS node speed (m/s)."""
        return substep(self.x, self.v, self.c, self.f, self.grid_m, self.grid_v, self.dt, self.h, self.origin,
                       self.mass, self.volume, self.mu, self.lam, gravity, damping)
