"""Numba kernels of the MLS-MPM stress solver (002 §4.2, after Hu et al. 2018): quadratic
B-splines, APIC transfers, the corotated model with the J that 002 Eq. 5 drops, float64 state.

Grid layout: MPM node n along an axis sits at ``origin + (n − 1)·h``: array index 1 is the
domain's low face (the ground along z), and the arrays have ``cells + 3`` nodes per axis so that
every particle inside the domain finds its 3 × 3 × 3 nodes.

Race-free, thread-count independent particle-to-grid transfer: particles are sorted (stably) by
the xy *block* of their base node (blocks of ``BLOCK`` × ``BLOCK`` base nodes, all z); blocks get one
of four colours by the parity of their block indices; the blocks of one colour are scattered in
parallel, each by one thread in sorted order. Two blocks of one colour are a block apart, and a
block writes only to the nodes of its base nodes + 2, so no node is written by two threads at
once, and each node receives its contributions in the same order whatever the thread count.
A particle may drift up to ``BLOCK − 2`` nodes from the block it was sorted into before this
stops holding; the solver re-sorts long before that.
"""

from __future__ import annotations

import numba
import numpy as np

#: Width, in base nodes, of the xy blocks of the race-free scatter (see the module docstring).
BLOCK = 4
#: Newton iterations of the polar decomposition stop at this change (max entry of R).
POLAR_TOLERANCE = 1e-15
POLAR_MAX_ITERATIONS = 30


@numba.njit(cache=True, inline="always")
def _cofactor(a00, a01, a02, a10, a11, a12, a20, a21, a22):
    """Cofactor matrix of a 3 × 3 matrix (= det · A^{-T}) and the determinant."""
    c00 = a11 * a22 - a12 * a21
    c01 = a12 * a20 - a10 * a22
    c02 = a10 * a21 - a11 * a20
    c10 = a02 * a21 - a01 * a22
    c11 = a00 * a22 - a02 * a20
    c12 = a01 * a20 - a00 * a21
    c20 = a01 * a12 - a02 * a11
    c21 = a02 * a10 - a00 * a12
    c22 = a00 * a11 - a01 * a10
    det = a00 * c00 + a01 * c01 + a02 * c02
    return c00, c01, c02, c10, c11, c12, c20, c21, c22, det


@numba.njit(cache=True)
def kirchhoff_stress(f: np.ndarray, mu: float, lam: float, tau: np.ndarray) -> float:
    """Kirchhoff stress τ = Jσ = 2μ(F − R)Fᵀ + λJ(J − 1)I of the corotated model (002 Eq. 5 with
    the J it drops on the λ term; Stomakhin et al. 2012) written into ``tau`` (3 × 3, Pa); returns
    J = det F. R from F = RS by Newton's iteration R ← (R + R^{-T})/2 (Higham 1986)."""
    r00, r01, r02 = f[0, 0], f[0, 1], f[0, 2]
    r10, r11, r12 = f[1, 0], f[1, 1], f[1, 2]
    r20, r21, r22 = f[2, 0], f[2, 1], f[2, 2]
    for _ in range(POLAR_MAX_ITERATIONS):
        c00, c01, c02, c10, c11, c12, c20, c21, c22, det = _cofactor(
            r00, r01, r02, r10, r11, r12, r20, r21, r22)
        inv = 1.0 / det
        n00, n01, n02 = 0.5 * (r00 + c00 * inv), 0.5 * (r01 + c01 * inv), 0.5 * (r02 + c02 * inv)
        n10, n11, n12 = 0.5 * (r10 + c10 * inv), 0.5 * (r11 + c11 * inv), 0.5 * (r12 + c12 * inv)
        n20, n21, n22 = 0.5 * (r20 + c20 * inv), 0.5 * (r21 + c21 * inv), 0.5 * (r22 + c22 * inv)
        change = max(abs(n00 - r00), abs(n01 - r01), abs(n02 - r02), abs(n10 - r10), abs(n11 - r11),
                     abs(n12 - r12), abs(n20 - r20), abs(n21 - r21), abs(n22 - r22))
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = n00, n01, n02, n10, n11, n12, n20, n21, n22
        if change < POLAR_TOLERANCE:
            break
    j = (f[0, 0] * (f[1, 1] * f[2, 2] - f[1, 2] * f[2, 1]) - f[0, 1] * (f[1, 0] * f[2, 2] - f[1, 2] * f[2, 0])
         + f[0, 2] * (f[1, 0] * f[2, 1] - f[1, 1] * f[2, 0]))
    d = ((f[0, 0] - r00, f[0, 1] - r01, f[0, 2] - r02),
         (f[1, 0] - r10, f[1, 1] - r11, f[1, 2] - r12),
         (f[2, 0] - r20, f[2, 1] - r21, f[2, 2] - r22))
    volumetric = lam * j * (j - 1.0)
    for a in range(3):
        for b in range(3):
            s = d[a][0] * f[b, 0] + d[a][1] * f[b, 1] + d[a][2] * f[b, 2]
            tau[a, b] = 2.0 * mu * s + (volumetric if a == b else 0.0)
    return j


@numba.njit(cache=True, parallel=True)
def cauchy_stress(deformation: np.ndarray, mu: float, lam: float) -> np.ndarray:
    """Cauchy stress σ = τ/J (Pa, tension positive) of every particle: ``(N, 3, 3)``."""
    n = deformation.shape[0]
    sigma = np.empty((n, 3, 3))
    for p in numba.prange(n):
        j = kirchhoff_stress(deformation[p], mu, lam, sigma[p])
        for a in range(3):
            for b in range(3):
                sigma[p, a, b] /= j
    return sigma


@numba.njit(cache=True, parallel=True)
def compressive_stress(deformation: np.ndarray, mu: float, lam: float) -> np.ndarray:
    """−tr σ (Pa) of every particle: compression positive, the quantity 002 Eq. 2 compares with I."""
    n = deformation.shape[0]
    out = np.empty(n)
    for p in numba.prange(n):
        tau = np.empty((3, 3))
        j = kirchhoff_stress(deformation[p], mu, lam, tau)
        out[p] = -(tau[0, 0] + tau[1, 1] + tau[2, 2]) / j
    return out


@numba.njit(cache=True, inline="always")
def _base(x: float, origin: float, inv_h: float) -> tuple[int, float]:
    """Array index of a particle's first node along one axis and its offset fx ∈ [0.5, 1.5)."""
    u = (x - origin) * inv_h
    b = int(np.floor(u - 0.5))
    return b + 1, u - b


@numba.njit(cache=True, inline="always")
def _weights(fx: float) -> tuple[float, float, float]:
    """Quadratic B-spline weights of the three nodes."""
    return 0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2


@numba.njit(cache=True, parallel=True)
def block_keys(positions: np.ndarray, origin: np.ndarray, h: float, blocks_y: int) -> np.ndarray:
    """The xy block (see the module docstring) of each particle's base node."""
    n = positions.shape[0]
    keys = np.empty(n, dtype=np.int64)
    inv_h = 1.0 / h
    for p in numba.prange(n):
        bx, _ = _base(positions[p, 0], origin[0], inv_h)
        by, _ = _base(positions[p, 1], origin[1], inv_h)
        keys[p] = (bx // BLOCK) * blocks_y + by // BLOCK
    return keys


@numba.njit(cache=True)
def counting_sort(keys: np.ndarray, key_count: int) -> tuple[np.ndarray, np.ndarray]:
    """Stable order of the particles by key and where each key's run starts (``key_count + 1``)."""
    starts = np.zeros(key_count + 1, dtype=np.int64)
    for k in keys:
        starts[k + 1] += 1
    for k in range(key_count):
        starts[k + 1] += starts[k]
    fill = starts[:-1].copy()
    order = np.empty(keys.shape[0], dtype=np.int64)
    for p in range(keys.shape[0]):
        order[fill[keys[p]]] = p
        fill[keys[p]] += 1
    return order, starts


@numba.njit(cache=True, parallel=True)
def particles_to_grid(order: np.ndarray, starts: np.ndarray, colour_blocks: np.ndarray,
                      colour_starts: np.ndarray, positions: np.ndarray, velocity: np.ndarray,
                      affine: np.ndarray, deformation: np.ndarray, mass: float, volume: float,
                      mu: float, lam: float, dt: float, origin: np.ndarray, h: float,
                      grid_mass: np.ndarray, grid_momentum: np.ndarray) -> None:
    """APIC transfer of mass and momentum plus the MLS stress force (002 §4.2 steps 1–2):
    ``grid_momentum`` receives Σ w (m v + (m C − Δt V⁰ (4/h²) τ)(x_i − x_p)), i.e. the momentum
    after the internal forces of one step. The grids must be zero on entry."""
    inv_h = 1.0 / h
    stress_scale = -dt * volume * 4.0 * inv_h * inv_h
    for colour in range(4):
        first, last = colour_starts[colour], colour_starts[colour + 1]
        for c in numba.prange(last - first):
            block = colour_blocks[first + c]
            tau = np.empty((3, 3))
            q = np.empty((3, 3))
            for s in range(starts[block], starts[block + 1]):
                p = order[s]
                kirchhoff_stress(deformation[p], mu, lam, tau)
                for a in range(3):
                    for b in range(3):
                        q[a, b] = stress_scale * tau[a, b] + mass * affine[p, a, b]
                bx, fx = _base(positions[p, 0], origin[0], inv_h)
                by, fy = _base(positions[p, 1], origin[1], inv_h)
                bz, fz = _base(positions[p, 2], origin[2], inv_h)
                wx = _weights(fx)
                wy = _weights(fy)
                wz = _weights(fz)
                mvx, mvy, mvz = mass * velocity[p, 0], mass * velocity[p, 1], mass * velocity[p, 2]
                for i in range(3):
                    dx = (i - fx) * h
                    for j in range(3):
                        dy = (j - fy) * h
                        wxy = wx[i] * wy[j]
                        for k in range(3):
                            dz = (k - fz) * h
                            w = wxy * wz[k]
                            grid_mass[bx + i, by + j, bz + k] += w * mass
                            grid_momentum[bx + i, by + j, bz + k, 0] += w * (
                                mvx + q[0, 0] * dx + q[0, 1] * dy + q[0, 2] * dz)
                            grid_momentum[bx + i, by + j, bz + k, 1] += w * (
                                mvy + q[1, 0] * dx + q[1, 1] * dy + q[1, 2] * dz)
                            grid_momentum[bx + i, by + j, bz + k, 2] += w * (
                                mvz + q[2, 0] * dx + q[2, 1] * dy + q[2, 2] * dz)


@numba.njit(cache=True, parallel=True)
def update_grid(grid_mass: np.ndarray, grid_momentum: np.ndarray, dt: float, gravity: float,
                damping: float) -> float:
    """Grid velocities (002 Eq. 6) in place of the momenta: v = (mv)/m + g Δt, damped by the
    factor (1 − ``damping``), with a ground the rock is bonded to (v = 0 on and below the
    domain's low z face, and no horizontal velocity on the first node level above it: no slip in
    the basal cell, whose particles otherwise take a third of their velocity from that level and
    let a wide layer spread on its base, ``test_mpm``) and roller side walls (no normal velocity
    on the domain's x and y faces); zero where there is no mass.

    Returns the mass-weighted RMS node speed sqrt(Σ m v² / Σ m) (m/s): nodes at the
    rock's fringe carry almost no mass and noisy velocities, which a maximum would report."""
    nx, ny, nz = grid_mass.shape
    slab_energy = np.zeros(nx)
    slab_mass = np.zeros(nx)
    keep = 1.0 - damping
    for i in numba.prange(nx):
        energy = 0.0
        total = 0.0
        for j in range(ny):
            for k in range(nz):
                m = grid_mass[i, j, k]
                if m <= 0.0 or k <= 1:
                    grid_momentum[i, j, k, 0] = 0.0
                    grid_momentum[i, j, k, 1] = 0.0
                    grid_momentum[i, j, k, 2] = 0.0
                    total += max(m, 0.0)
                    continue
                vx = grid_momentum[i, j, k, 0] / m * keep
                vy = grid_momentum[i, j, k, 1] / m * keep
                vz = (grid_momentum[i, j, k, 2] / m - gravity * dt) * keep
                if i <= 1 or i >= nx - 2 or k == 2:
                    vx = 0.0
                if j <= 1 or j >= ny - 2 or k == 2:
                    vy = 0.0
                grid_momentum[i, j, k, 0] = vx
                grid_momentum[i, j, k, 1] = vy
                grid_momentum[i, j, k, 2] = vz
                energy += m * (vx * vx + vy * vy + vz * vz)
                total += m
        slab_energy[i] = energy
        slab_mass[i] = total
    mass = slab_mass.sum()
    return np.sqrt(slab_energy.sum() / mass) if mass > 0.0 else 0.0


@numba.njit(cache=True, parallel=True)
def scatter_values(order: np.ndarray, starts: np.ndarray, colour_blocks: np.ndarray,
                   colour_starts: np.ndarray, positions: np.ndarray, values: np.ndarray,
                   origin: np.ndarray, h: float, grid_weight: np.ndarray, grid_values: np.ndarray) -> None:
    """Σ w and Σ w·value of per-particle ``values`` (N, m) on the nodes (race-free, like
    :func:`particles_to_grid`); the grids must be zero on entry."""
    inv_h = 1.0 / h
    m = values.shape[1]
    for colour in range(4):
        first, last = colour_starts[colour], colour_starts[colour + 1]
        for c in numba.prange(last - first):
            block = colour_blocks[first + c]
            for s in range(starts[block], starts[block + 1]):
                p = order[s]
                bx, fx = _base(positions[p, 0], origin[0], inv_h)
                by, fy = _base(positions[p, 1], origin[1], inv_h)
                bz, fz = _base(positions[p, 2], origin[2], inv_h)
                wx = _weights(fx)
                wy = _weights(fy)
                wz = _weights(fz)
                for i in range(3):
                    for j in range(3):
                        for k in range(3):
                            w = wx[i] * wy[j] * wz[k]
                            grid_weight[bx + i, by + j, bz + k] += w
                            for a in range(m):
                                grid_values[bx + i, by + j, bz + k, a] += w * values[p, a]


@numba.njit(cache=True, parallel=True)
def gather_values(grid_weight: np.ndarray, grid_values: np.ndarray, positions: np.ndarray,
                  origin: np.ndarray, h: float) -> np.ndarray:
    """At each particle, Σ w·(node average) over its nodes, renormalised over the nodes that
    received values: the B-spline smoothing of a per-particle field (N, m)."""
    inv_h = 1.0 / h
    m = grid_values.shape[3]
    out = np.zeros((positions.shape[0], m))
    for p in numba.prange(positions.shape[0]):
        bx, fx = _base(positions[p, 0], origin[0], inv_h)
        by, fy = _base(positions[p, 1], origin[1], inv_h)
        bz, fz = _base(positions[p, 2], origin[2], inv_h)
        wx = _weights(fx)
        wy = _weights(fy)
        wz = _weights(fz)
        total = 0.0
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    g = grid_weight[bx + i, by + j, bz + k]
                    if g > 0.0:
                        w = wx[i] * wy[j] * wz[k]
                        total += w
                        for a in range(m):
                            out[p, a] += w * grid_values[bx + i, by + j, bz + k, a] / g
        for a in range(m):
            out[p, a] /= total
    return out


@numba.njit(cache=True, parallel=True)
def grid_to_particles(grid_velocity: np.ndarray, positions: np.ndarray, velocity: np.ndarray,
                      affine: np.ndarray, deformation: np.ndarray, dt: float, origin: np.ndarray,
                      h: float, upper: np.ndarray) -> None:
    """Gather velocity and APIC matrix C = (4/h²) Σ w v_i (x_i − x_p)ᵀ, advect (kept inside the
    domain, below ``upper``), and F ← (I + Δt C) F (002 §4.2 steps 4–5)."""
    inv_h = 1.0 / h
    scale = 4.0 * inv_h * inv_h
    for p in numba.prange(positions.shape[0]):
        bx, fx = _base(positions[p, 0], origin[0], inv_h)
        by, fy = _base(positions[p, 1], origin[1], inv_h)
        bz, fz = _base(positions[p, 2], origin[2], inv_h)
        wx = _weights(fx)
        wy = _weights(fy)
        wz = _weights(fz)
        v0 = v1 = v2 = 0.0
        c00 = c01 = c02 = c10 = c11 = c12 = c20 = c21 = c22 = 0.0
        for i in range(3):
            dx = (i - fx) * h
            for j in range(3):
                dy = (j - fy) * h
                wxy = wx[i] * wy[j]
                for k in range(3):
                    dz = (k - fz) * h
                    w = wxy * wz[k]
                    gx = grid_velocity[bx + i, by + j, bz + k, 0]
                    gy = grid_velocity[bx + i, by + j, bz + k, 1]
                    gz = grid_velocity[bx + i, by + j, bz + k, 2]
                    v0 += w * gx
                    v1 += w * gy
                    v2 += w * gz
                    wg = w * scale
                    c00 += wg * gx * dx
                    c01 += wg * gx * dy
                    c02 += wg * gx * dz
                    c10 += wg * gy * dx
                    c11 += wg * gy * dy
                    c12 += wg * gy * dz
                    c20 += wg * gz * dx
                    c21 += wg * gz * dy
                    c22 += wg * gz * dz
        velocity[p, 0], velocity[p, 1], velocity[p, 2] = v0, v1, v2
        positions[p, 0] = min(max(positions[p, 0] + dt * v0, origin[0]), upper[0])
        positions[p, 1] = min(max(positions[p, 1] + dt * v1, origin[1]), upper[1])
        positions[p, 2] = min(max(positions[p, 2] + dt * v2, origin[2]), upper[2])
        affine[p, 0, 0], affine[p, 0, 1], affine[p, 0, 2] = c00, c01, c02
        affine[p, 1, 0], affine[p, 1, 1], affine[p, 1, 2] = c10, c11, c12
        affine[p, 2, 0], affine[p, 2, 1], affine[p, 2, 2] = c20, c21, c22
        for b in range(3):
            f0, f1, f2 = deformation[p, 0, b], deformation[p, 1, b], deformation[p, 2, b]
            deformation[p, 0, b] = f0 + dt * (c00 * f0 + c01 * f1 + c02 * f2)
            deformation[p, 1, b] = f1 + dt * (c10 * f0 + c11 * f1 + c12 * f2)
            deformation[p, 2, b] = f2 + dt * (c20 * f0 + c21 * f1 + c22 * f2)


@numba.njit(cache=True, parallel=True)
def clear(grid_mass: np.ndarray, grid_momentum: np.ndarray) -> None:
    """Zero the grid (in parallel, slab by slab)."""
    for i in numba.prange(grid_mass.shape[0]):
        grid_mass[i] = 0.0
        grid_momentum[i] = 0.0
