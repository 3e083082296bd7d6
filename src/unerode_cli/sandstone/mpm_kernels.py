"""Numba kernels of the MLS-MPM stress solver (002 §4.2, after Hu et al. 2018): quadratic
B-splines, APIC transfers, the corotated model with the J that 002 Eq. 5 drops, float64 state.

Grid layout: MPM node n along an axis sits at ``origin + (n − 1)·h``: array index 1 is the
domain's low face (the ground along z), and the arrays have ``cells + 3`` nodes per axis so that
every particle inside the domain finds its 3 × 3 × 3 nodes. The grid is one array
``(nx, ny, nz, 4)``: momentum (x, y, z) and mass of each node, the momentum replaced by the
velocity by :func:`update_grid`. A substep works on the box of nodes the particles reach
(:func:`node_bounds`, also returned by :func:`grid_to_particles`); the grid is zero outside it
and :func:`clear` zeroes it again after the step.

Race-free, thread-count independent particle-to-grid transfer: particles are sorted (stably) by
the xy *block* of their base node (blocks of ``BLOCK`` × ``BLOCK`` base nodes, all z); blocks get one
of four colours by the parity of their block indices; the blocks of one colour are scattered in
parallel, each by one thread in sorted order. Two blocks of one colour are a block apart, and a
block writes only to the nodes of its base nodes + 2, so no node is written by two threads at
once, and each node receives its contributions in the same order whatever the thread count.
A particle may drift up to ``BLOCK − 2`` nodes from the block it was sorted into before this
stops holding; the solver re-sorts long before that. The other kernels loop over fixed chunks
of particles or slabs of nodes and combine them in a fixed order.

Stress: with F = I + H, B = FFᵀ = I + E (E = H + Hᵀ + HHᵀ) and V = √B the left stretch, the
corotated Kirchhoff stress is τ = 2μ(F − R)Fᵀ + λJ(J − 1)I = 2μ(B − V) + λJ(J − 1)I, and
B − V = E/2 + E²/8 − E³/16 + 5E⁴/128 − … (the series of x − (√(1 + x) − 1)), exact to a
relative 7‖E‖⁴/128 (< 6e-10 below ``SERIES_LIMIT``), free of the cancellation of F − R, and independent of
the rotation. Larger strains take R from Newton's polar iteration R ← (R + R⁻ᵀ)/2 (Higham 1986).
J − 1 = tr H + ((tr H)² − tr H²)/2 + det H, also without cancellation.
"""

from __future__ import annotations

import numba
import numpy as np

#: Width, in base nodes, of the xy blocks of the race-free scatter (see the module docstring).
BLOCK = 4
#: Strains ‖E‖ (Frobenius norm of FFᵀ − I) below this take the series (module docstring).
SERIES_LIMIT = 1e-2
#: Newton iterations of the polar decomposition stop at this change (max entry of R).
POLAR_TOLERANCE = 1e-15
POLAR_MAX_ITERATIONS = 30
#: Particle chunks of the gather (a fixed count: the bounds do not depend on the threads).
CHUNKS = 256


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
def _polar_stretch(f: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """(F − R)Fᵀ = B − V (xx, yy, zz, xy, xz, yz) with R from F = RS by Newton's iteration."""
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
    d = ((f[0, 0] - r00, f[0, 1] - r01, f[0, 2] - r02),
         (f[1, 0] - r10, f[1, 1] - r11, f[1, 2] - r12),
         (f[2, 0] - r20, f[2, 1] - r21, f[2, 2] - r22))
    s = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            s[a, b] = d[a][0] * f[b, 0] + d[a][1] * f[b, 1] + d[a][2] * f[b, 2]
    return (s[0, 0], s[1, 1], s[2, 2], 0.5 * (s[0, 1] + s[1, 0]), 0.5 * (s[0, 2] + s[2, 0]),
            0.5 * (s[1, 2] + s[2, 1]))


@numba.njit(cache=True, inline="always")
def _times_e(a00, a11, a22, a01, a02, a12, e00, e11, e22, e01, e02, e12):
    """A·E of two commuting symmetric 3 × 3 matrices (xx, yy, zz, xy, xz, yz)."""
    return (a00 * e00 + a01 * e01 + a02 * e02, a01 * e01 + a11 * e11 + a12 * e12,
            a02 * e02 + a12 * e12 + a22 * e22, a00 * e01 + a01 * e11 + a02 * e12,
            a00 * e02 + a01 * e12 + a02 * e22, a01 * e02 + a11 * e12 + a12 * e22)


@numba.njit(cache=True, inline="always")
def _kirchhoff(f: np.ndarray, mu: float, lam: float):
    """Kirchhoff stress τ = 2μ(B − V) + λJ(J − 1)I of the corotated model (002 Eq. 5 with the J it
    drops on the λ term; Stomakhin et al. 2012) of F (3 × 3): (xx, yy, zz, xy, xz, yz) in Pa, and
    J = det F. B − V by its series below ``SERIES_LIMIT``, else by the polar decomposition."""
    h00, h01, h02 = f[0, 0] - 1.0, f[0, 1], f[0, 2]
    h10, h11, h12 = f[1, 0], f[1, 1] - 1.0, f[1, 2]
    h20, h21, h22 = f[2, 0], f[2, 1], f[2, 2] - 1.0
    e00 = 2.0 * h00 + h00 * h00 + h01 * h01 + h02 * h02
    e11 = 2.0 * h11 + h10 * h10 + h11 * h11 + h12 * h12
    e22 = 2.0 * h22 + h20 * h20 + h21 * h21 + h22 * h22
    e01 = h01 + h10 + h00 * h10 + h01 * h11 + h02 * h12
    e02 = h02 + h20 + h00 * h20 + h01 * h21 + h02 * h22
    e12 = h12 + h21 + h10 * h20 + h11 * h21 + h12 * h22
    trace = h00 + h11 + h22
    square = h00 * h00 + h11 * h11 + h22 * h22 + 2.0 * (h01 * h10 + h02 * h20 + h12 * h21)
    det = (h00 * (h11 * h22 - h12 * h21) - h01 * (h10 * h22 - h12 * h20) + h02 * (h10 * h21 - h11 * h20))
    jm1 = trace + 0.5 * (trace * trace - square) + det
    norm = e00 * e00 + e11 * e11 + e22 * e22 + 2.0 * (e01 * e01 + e02 * e02 + e12 * e12)
    if norm < SERIES_LIMIT * SERIES_LIMIT:
        c = 5.0 / 128.0
        p = _times_e(c, c, c, 0.0, 0.0, 0.0, e00, e11, e22, e01, e02, e12)
        p = _times_e(p[0] - 0.0625, p[1] - 0.0625, p[2] - 0.0625, p[3], p[4], p[5],
                     e00, e11, e22, e01, e02, e12)
        p = _times_e(p[0] + 0.125, p[1] + 0.125, p[2] + 0.125, p[3], p[4], p[5], e00, e11, e22, e01, e02, e12)
        s = _times_e(p[0] + 0.5, p[1] + 0.5, p[2] + 0.5, p[3], p[4], p[5], e00, e11, e22, e01, e02, e12)
    else:
        s = _polar_stretch(f)
    volumetric = lam * (1.0 + jm1) * jm1
    two_mu = 2.0 * mu
    return (two_mu * s[0] + volumetric, two_mu * s[1] + volumetric, two_mu * s[2] + volumetric,
            two_mu * s[3], two_mu * s[4], two_mu * s[5], 1.0 + jm1)


@numba.njit(cache=True)
def kirchhoff_stress(f: np.ndarray, mu: float, lam: float, tau: np.ndarray) -> float:
    """Kirchhoff stress τ = Jσ (Pa) of F (3 × 3) written into ``tau`` (3 × 3); returns J = det F."""
    t00, t11, t22, t01, t02, t12, j = _kirchhoff(f, mu, lam)
    tau[0, 0], tau[1, 1], tau[2, 2] = t00, t11, t22
    tau[0, 1] = tau[1, 0] = t01
    tau[0, 2] = tau[2, 0] = t02
    tau[1, 2] = tau[2, 1] = t12
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
        t00, t11, t22, _, _, _, j = _kirchhoff(deformation[p], mu, lam)
        out[p] = -(t00 + t11 + t22) / j
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


@numba.njit(cache=True)
def _stencil(position: np.ndarray, origin: np.ndarray, inv_h: float):
    """A particle's 3 × 3 × 3 stencil: its base node (bx, by, bz) and B-spline weights (wx, wy, wz)
    along each axis."""
    bx, fx = _base(position[0], origin[0], inv_h)
    by, fy = _base(position[1], origin[1], inv_h)
    bz, fz = _base(position[2], origin[2], inv_h)
    return bx, by, bz, _weights(fx), _weights(fy), _weights(fz)


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


@numba.njit(cache=True)
def _empty_bounds() -> np.ndarray:
    """Per chunk of particles, an empty box of nodes (lowest above highest), ``(CHUNKS, 2, 3)``."""
    bounds = np.empty((CHUNKS, 2, 3), dtype=np.int64)
    bounds[:, 0, :] = np.iinfo(np.int64).max
    bounds[:, 1, :] = np.iinfo(np.int64).min
    return bounds


@numba.njit(cache=True, parallel=True)
def node_bounds(positions: np.ndarray, origin: np.ndarray, h: float) -> np.ndarray:
    """The box of nodes the particles' stencils reach: lowest base node and highest base node
    + 2 along each axis (inclusive array indices), ``(2, 3)`` int64."""
    n = positions.shape[0]
    inv_h = 1.0 / h
    size = (n + CHUNKS - 1) // CHUNKS
    bounds = _empty_bounds()
    for c in numba.prange(CHUNKS):
        for p in range(c * size, min(n, (c + 1) * size)):
            for a in range(3):
                b, _ = _base(positions[p, a], origin[a], inv_h)
                bounds[c, 0, a] = min(bounds[c, 0, a], b)
                bounds[c, 1, a] = max(bounds[c, 1, a], b + 2)
    return _combined(bounds)


@numba.njit(cache=True)
def _combined(bounds: np.ndarray) -> np.ndarray:
    """The box holding every chunk's box."""
    out = np.empty((2, 3), dtype=np.int64)
    for a in range(3):
        out[0, a] = bounds[:, 0, a].min()
        out[1, a] = bounds[:, 1, a].max()
    return out


@numba.njit(cache=True, inline="always")
def _scatter_particle(p, positions, velocity, affine, deformation, mass, mu, lam, stress_scale, origin,
                      h, inv_h, grid):
    """Add particle ``p``'s mass and momentum after its stress force (see
    :func:`particles_to_grid`) to its 27 nodes: with Q = m C − Δt V⁰ (4/h²) τ, node (i, j, k)
    receives w (m v − Q f h + Q (i, j, k) h), the per-node part built axis by axis."""
    t00, t11, t22, t01, t02, t12, _ = _kirchhoff(deformation[p], mu, lam)
    q00 = stress_scale * t00 + mass * affine[p, 0, 0]
    q01 = stress_scale * t01 + mass * affine[p, 0, 1]
    q02 = stress_scale * t02 + mass * affine[p, 0, 2]
    q10 = stress_scale * t01 + mass * affine[p, 1, 0]
    q11 = stress_scale * t11 + mass * affine[p, 1, 1]
    q12 = stress_scale * t12 + mass * affine[p, 1, 2]
    q20 = stress_scale * t02 + mass * affine[p, 2, 0]
    q21 = stress_scale * t12 + mass * affine[p, 2, 1]
    q22 = stress_scale * t22 + mass * affine[p, 2, 2]
    bx, fx = _base(positions[p, 0], origin[0], inv_h)
    by, fy = _base(positions[p, 1], origin[1], inv_h)
    bz, fz = _base(positions[p, 2], origin[2], inv_h)
    wx = _weights(fx)
    wy = _weights(fy)
    wz = _weights(fz)
    a0 = mass * velocity[p, 0] - h * (q00 * fx + q01 * fy + q02 * fz)
    a1 = mass * velocity[p, 1] - h * (q10 * fx + q11 * fy + q12 * fz)
    a2 = mass * velocity[p, 2] - h * (q20 * fx + q21 * fy + q22 * fz)
    for i in range(3):
        b0, b1, b2 = a0 + i * h * q00, a1 + i * h * q10, a2 + i * h * q20
        for j in range(3):
            c0, c1, c2 = b0 + j * h * q01, b1 + j * h * q11, b2 + j * h * q21
            wij = wx[i] * wy[j]
            for k in range(3):
                w = wij * wz[k]
                node = grid[bx + i, by + j, bz + k]
                node[0] += w * (c0 + k * h * q02)
                node[1] += w * (c1 + k * h * q12)
                node[2] += w * (c2 + k * h * q22)
                node[3] += w * mass


@numba.njit(cache=True, parallel=True)
def particles_to_grid(order: np.ndarray, starts: np.ndarray, colour_blocks: np.ndarray,
                      colour_starts: np.ndarray, positions: np.ndarray, velocity: np.ndarray,
                      affine: np.ndarray, deformation: np.ndarray, masses: np.ndarray, volumes: np.ndarray,
                      mu: float, lam: float, dt: float, origin: np.ndarray, h: float,
                      grid: np.ndarray) -> None:
    """APIC transfer of mass and momentum plus the MLS stress force (002 §4.2 steps 1–2): the
    ``grid`` (momentum, mass) receives Σ w (m v + (m C − Δt V⁰ (4/h²) τ)(x_i − x_p)) and Σ w m,
    i.e. the momentum after the internal forces of one step. ``masses`` (kg) and ``volumes``
    (m³) hold one value per particle, or one value (length 1) shared by all. The grid must be
    zero on entry."""
    inv_h = 1.0 / h
    scale = -dt * 4.0 * inv_h * inv_h
    stride = 1 if masses.shape[0] > 1 else 0
    for colour in range(4):
        first, last = colour_starts[colour], colour_starts[colour + 1]
        for c in numba.prange(last - first):
            block = colour_blocks[first + c]
            for s in range(starts[block], starts[block + 1]):
                p = order[s]
                _scatter_particle(p, positions, velocity, affine, deformation, masses[p * stride], mu, lam,
                                  scale * volumes[p * stride], origin, h, inv_h, grid)


@numba.njit(cache=True, parallel=True)
def update_grid(grid: np.ndarray, bounds: np.ndarray, dt: float, gravity: float, damping: float) -> float:
    """Grid velocities (002 Eq. 6) in place of the momenta, in the box ``bounds`` (the grid is
    zero outside it): v = (mv)/m + g Δt, damped by the factor (1 − ``damping``), with a ground
    the rock is bonded to (v = 0 on and below the domain's low z face, and no horizontal velocity
    on the first node level above it: no slip in the basal cell, whose particles otherwise take
    a third of their velocity from that level and let a wide layer spread on its base,
    ``test_mpm``) and roller side walls (no normal velocity on the domain's x and y faces); zero
    where there is no mass.

    Returns the mass-weighted RMS node speed sqrt(Σ m v² / Σ m) (m/s): nodes at the
    rock's fringe carry almost no mass and noisy velocities, which a maximum would report."""
    nx, ny, _, _ = grid.shape
    (lx, ly, lz), (hx, hy, hz) = bounds[0], bounds[1]
    slab_energy = np.zeros(hx - lx + 1)
    slab_mass = np.zeros(hx - lx + 1)
    keep = 1.0 - damping
    for s in numba.prange(hx - lx + 1):
        i = lx + s
        energy = 0.0
        total = 0.0
        for j in range(ly, hy + 1):
            for k in range(lz, hz + 1):
                node = grid[i, j, k]
                m = node[3]
                if m <= 0.0 or k <= 1:
                    node[0] = node[1] = node[2] = 0.0
                    total += max(m, 0.0)
                    continue
                vx = node[0] / m * keep
                vy = node[1] / m * keep
                vz = (node[2] / m - gravity * dt) * keep
                if i <= 1 or i >= nx - 2 or k == 2:
                    vx = 0.0
                if j <= 1 or j >= ny - 2 or k == 2:
                    vy = 0.0
                node[0], node[1], node[2] = vx, vy, vz
                energy += m * (vx * vx + vy * vy + vz * vz)
                total += m
        slab_energy[s] = energy
        slab_mass[s] = total
    mass = slab_mass.sum()
    return np.sqrt(slab_energy.sum() / mass) if mass > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def _gather(grid, bx, by, bz, wx, wy, wz):
    """Σ w v, Σ w v i, Σ w v j and Σ w v k over a particle's 27 nodes (i, j, k ∈ 0..2 its node
    offsets), each (x, y, z): 12 numbers, summed axis by axis."""
    s0x = s0y = s0z = six = siy = siz = sjx = sjy = sjz = skx = sky = skz = 0.0
    for i in range(3):
        u0x = u0y = u0z = ujx = ujy = ujz = ukx = uky = ukz = 0.0
        for j in range(3):
            x0, y0, z0 = grid[bx + i, by + j, bz, 0], grid[bx + i, by + j, bz, 1], grid[bx + i, by + j, bz, 2]
            x1, y1, z1 = (grid[bx + i, by + j, bz + 1, 0], grid[bx + i, by + j, bz + 1, 1],
                          grid[bx + i, by + j, bz + 1, 2])
            x2, y2, z2 = (grid[bx + i, by + j, bz + 2, 0], grid[bx + i, by + j, bz + 2, 1],
                          grid[bx + i, by + j, bz + 2, 2])
            wj = wy[j]
            kx = wz[1] * x1 + 2.0 * wz[2] * x2
            ky = wz[1] * y1 + 2.0 * wz[2] * y2
            kz = wz[1] * z1 + 2.0 * wz[2] * z2
            tx = wz[0] * x0 + wz[1] * x1 + wz[2] * x2
            ty = wz[0] * y0 + wz[1] * y1 + wz[2] * y2
            tz = wz[0] * z0 + wz[1] * z1 + wz[2] * z2
            u0x, u0y, u0z = u0x + wj * tx, u0y + wj * ty, u0z + wj * tz
            ujx, ujy, ujz = ujx + j * wj * tx, ujy + j * wj * ty, ujz + j * wj * tz
            ukx, uky, ukz = ukx + wj * kx, uky + wj * ky, ukz + wj * kz
        wi = wx[i]
        s0x, s0y, s0z = s0x + wi * u0x, s0y + wi * u0y, s0z + wi * u0z
        six, siy, siz = six + i * wi * u0x, siy + i * wi * u0y, siz + i * wi * u0z
        sjx, sjy, sjz = sjx + wi * ujx, sjy + wi * ujy, sjz + wi * ujz
        skx, sky, skz = skx + wi * ukx, sky + wi * uky, skz + wi * ukz
    return s0x, s0y, s0z, six, siy, siz, sjx, sjy, sjz, skx, sky, skz


@numba.njit(cache=True, parallel=True)
def grid_to_particles(grid: np.ndarray, positions: np.ndarray, velocity: np.ndarray, affine: np.ndarray,
                      deformation: np.ndarray, dt: float, origin: np.ndarray, h: float,
                      upper: np.ndarray) -> np.ndarray:
    """Gather velocity and APIC matrix C = (4/h²) Σ w v_i (x_i − x_p)ᵀ = (4/h)(Σ w v_i (i − f)),
    advect (kept inside the domain, below ``upper``), and F ← (I + Δt C) F (002 §4.2 steps 4–5).
    Returns the box of nodes of the particles' new stencils (as :func:`node_bounds`)."""
    n = positions.shape[0]
    inv_h = 1.0 / h
    scale = 4.0 * inv_h
    size = (n + CHUNKS - 1) // CHUNKS
    bounds = _empty_bounds()
    for chunk in numba.prange(CHUNKS):
        for p in range(chunk * size, min(n, (chunk + 1) * size)):
            bx, fx = _base(positions[p, 0], origin[0], inv_h)
            by, fy = _base(positions[p, 1], origin[1], inv_h)
            bz, fz = _base(positions[p, 2], origin[2], inv_h)
            v0, v1, v2, i0, i1, i2, j0, j1, j2, k0, k1, k2 = _gather(grid, bx, by, bz, _weights(fx),
                                                                     _weights(fy), _weights(fz))
            c00, c01, c02 = scale * (i0 - fx * v0), scale * (j0 - fy * v0), scale * (k0 - fz * v0)
            c10, c11, c12 = scale * (i1 - fx * v1), scale * (j1 - fy * v1), scale * (k1 - fz * v1)
            c20, c21, c22 = scale * (i2 - fx * v2), scale * (j2 - fy * v2), scale * (k2 - fz * v2)
            velocity[p, 0], velocity[p, 1], velocity[p, 2] = v0, v1, v2
            affine[p, 0, 0], affine[p, 0, 1], affine[p, 0, 2] = c00, c01, c02
            affine[p, 1, 0], affine[p, 1, 1], affine[p, 1, 2] = c10, c11, c12
            affine[p, 2, 0], affine[p, 2, 1], affine[p, 2, 2] = c20, c21, c22
            for b in range(3):
                f0, f1, f2 = deformation[p, 0, b], deformation[p, 1, b], deformation[p, 2, b]
                deformation[p, 0, b] = f0 + dt * (c00 * f0 + c01 * f1 + c02 * f2)
                deformation[p, 1, b] = f1 + dt * (c10 * f0 + c11 * f1 + c12 * f2)
                deformation[p, 2, b] = f2 + dt * (c20 * f0 + c21 * f1 + c22 * f2)
            for a, va in ((0, v0), (1, v1), (2, v2)):
                x = min(max(positions[p, a] + dt * va, origin[a]), upper[a])
                positions[p, a] = x
                b, _ = _base(x, origin[a], inv_h)
                bounds[chunk, 0, a] = min(bounds[chunk, 0, a], b)
                bounds[chunk, 1, a] = max(bounds[chunk, 1, a], b + 2)
    return _combined(bounds)


@numba.njit(cache=True, parallel=True)
def clear(grid: np.ndarray, bounds: np.ndarray) -> None:
    """Zero the box ``bounds`` of the grid (in parallel, slab by slab)."""
    (lx, ly, lz), (hx, hy, hz) = bounds[0], bounds[1]
    for i in numba.prange(lx, hx + 1):
        grid[i, ly:hy + 1, lz:hz + 1, :] = 0.0


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
                bx, by, bz, wx, wy, wz = _stencil(positions[p], origin, inv_h)
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
        bx, by, bz, wx, wy, wz = _stencil(positions[p], origin, inv_h)
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
def accumulate(grid: np.ndarray, bounds: np.ndarray, dt: float, total: np.ndarray) -> None:
    """Add Δt × the node velocities of ``grid`` (after :func:`update_grid`) in the box ``bounds``
    to the displacements ``total`` ``(nx, ny, nz, 4)`` (m; component 3 unused)."""
    (lx, ly, lz), (hx, hy, hz) = bounds[0], bounds[1]
    for i in numba.prange(lx, hx + 1):
        for j in range(ly, hy + 1):
            for k in range(lz, hz + 1):
                for a in range(3):
                    total[i, j, k, a] += dt * grid[i, j, k, a]
