"""Numba kernels of implicit terrains (003 §4.3, metaballs of 003 Eq. 11): f (m) of a compiled
scene (``sdf_shapes``) and of its metaballs, the node cache, and the ground volume under it.

Metaballs (003 Eq. 11): a change of volume Q (m³, > 0 deposits) at a surface point c with
radius R adds a metaball of compact support, m(p) = a·max(0, 1 − t/R)·w(s/R), with d̂ the
direction the change moves the surface (the outward normal for a deposit, inward for
erosion), s = d̂·(p − c) the distance along it, t = ‖p − c − s·d̂‖ the distance across it, and
w = 1 from ``BEHIND``·R behind the surface (s < 0) to R/2 ahead of it, falling linearly to 0
at R ahead and at (``BEHIND`` + ½)·R behind. The composition is the sum f̃ = f + Σ m, so
eroding then depositing the same metaball (same centre, radius and d̂) restores f (to
rounding). Where w = 1 m is constant along d̂, so a plane moves by exactly a·(1 − t/R): 003
Eq. 9's cone profile (1 − d/R, Eq. 11) laid on the surface, lifting ∫₀ᴿ(1 − t/R)·2πt dt =
πR²/3 per metre of a, hence a = −3Q/(πR²) (m) to start with. This departs from 003, for the
volume to be Q: Eq. 11 (its appendix, Eq. 15–17) scales the cone so that its *volume*
integral is Q (λ = 3Q/(πR³)), which suits a density (voxels, Eq. 13) but not a distance, whose
surface moves by what is added to it; Eq. 11's cone is round (d = ‖p − c‖), which lifts a
plane by less than a near c and, sampled on nodes a radius apart along z, loses a quarter of
its volume to the linear interpolation between them, where m constant along d̂ loses nothing;
and a metaball that faded within R behind the surface would, under a pile of deposits taller
than R/2 (or a pit as deep), make f decrease upwards and the pile hollow out, where one that
reaches far behind keeps f growing outwards. A change with |a| > R/2 is spread over the radius
at which |a| = R/2, and a radius below ``MIN_RADIUS`` node spacings is widened to it (the cache
cannot hold a narrower cone: at one spacing about 6 % of its volume falls between the nodes,
at 1.5 under 0.1 %; on a heightfield a footprint narrower than a cell likewise goes to the
nearest cell).

Changes are placed in order, each put on the surface as the ones before left it
(``place_changes``): all the impacts of an iteration are traced on one frozen terrain, and a
change left above or below the surface would move less matter. Off a plane the lift differs
from πR²|a|/3: on a curved surface the lift along the fixed d̂ covers a cap larger than its
disc (1 + 0.15·(κR)² on a sphere of curvature κ), in a gully or on a thin ridge the walls or
the far side within reach move too, and a metaball at the grid's border lifts a part outside
it. So a is then set so that the ground of the cache along its columns — what the top
heightfield and ``ImplicitField.inside_volume`` read — changes by exactly Q over the valid columns (secant
steps on a, the change measured on the columns and layers the metaball reaches). The exact
field follows to within the cache's interpolation where the surface faces up (0.15 % on
DEMs); columns cross a steep wall at grazing angles and measure its moves coarsely (on a
sphere's flanks, 4 % for R = 4 node spacings, 0.6 % for 8).

Frame and units as in ``sdf_shapes``: x, y, z and f in m, node (voxel centre) values of a
``volume.voxels.VoxelGeometry`` at (column·dx, row·dy, z0 + (layer + ½)·dz).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from unerode_cli.volume.sdf_shapes import BOX, CAPSULE, DIFFERENCE, PLANE, SPHERE, SURFACE, UNION
from unerode_cli.volume.voxel_kernels import bilinear, cell_frac

#: Largest |a|/R = 3|Q|/(πR³) of a metaball; a larger change is spread over a wider one.
U_MAX = 0.5
#: Smallest metaball radius, in node spacings (the largest of dx, dy, dz).
MIN_RADIUS = 1.5
#: Secant steps that size a metaball on the cache, the relative error at which they stop, and
#: the most they may scale the first amplitude (a change the cache hardly sees is not blown up).
SIZE_STEPS = 3
SIZE_TOLERANCE = 1e-6
SIZE_CAP = 4.0
#: Newton steps that put a change on the surface, the longest move of one, the |f| at which a
#: point is on the surface and the |f| beyond which they missed it (all in node spacings).
NEWTON_STEPS = 4
NEWTON_MOVE = 1.0
NEWTON_TOLERANCE = 1e-6
NEWTON_MISS = 0.01
#: Columns of the metaball table: centre (m), radius R (m), amplitude a (m), and the unit
#: direction d̂ the surface moves (outward for a deposit).
BALL_X, BALL_Y, BALL_Z, BALL_R, BALL_A, BALL_NX, BALL_NY, BALL_NZ = range(8)
BALL_COLUMNS = 8
#: How far a metaball reaches behind the surface it moves, in radii (module docstring).
BEHIND = 4.0


@numba.njit(cache=True)
def _trilinear(g, col, row, layer):
    """Trilinear g[row, column, layer] at node coordinates (col, row, layer), clamped."""
    ny, nx, nz = g.shape
    c, fx = cell_frac(col, nx)
    r, fy = cell_frac(row, ny)
    k, fz = cell_frac(layer, nz)
    c1, r1, k1 = min(c + 1, nx - 1), min(r + 1, ny - 1), min(k + 1, nz - 1)
    lo = ((g[r, c, k] * (1.0 - fx) + g[r, c1, k] * fx) * (1.0 - fy)
          + (g[r1, c, k] * (1.0 - fx) + g[r1, c1, k] * fx) * fy)
    hi = ((g[r, c, k1] * (1.0 - fx) + g[r, c1, k1] * fx) * (1.0 - fy)
          + (g[r1, c, k1] * (1.0 - fx) + g[r1, c1, k1] * fx) * fy)
    return lo * (1.0 - fz) + hi * fz


@numba.njit(cache=True)
def _primitive(code, prm, heights, norms, grid, dx, dy, z0, dz, x, y, z):
    """f (m) of one primitive at (x, y, z) (m, the frame); ``prm`` its parameters."""
    if code == SURFACE:
        col, row = x / dx, y / dy
        return (z - bilinear(heights, col, row)) / bilinear(norms, col, row)
    if code == PLANE:
        return prm[3] * (x - prm[0]) + prm[4] * (y - prm[1]) + prm[5] * (z - prm[2])
    if code == BOX:
        qx, qy, qz = abs(x - prm[0]) - prm[3], abs(y - prm[1]) - prm[4], abs(z - prm[2]) - prm[5]
        outside = math.sqrt(max(qx, 0.0) ** 2 + max(qy, 0.0) ** 2 + max(qz, 0.0) ** 2)
        return outside + min(max(qx, qy, qz), 0.0)
    if code == SPHERE:
        return math.sqrt((x - prm[0]) ** 2 + (y - prm[1]) ** 2 + (z - prm[2]) ** 2) - prm[3]
    if code == CAPSULE:
        px, py, pz = x - prm[0], y - prm[1], z - prm[2]
        bx, by, bz = prm[3] - prm[0], prm[4] - prm[1], prm[5] - prm[2]
        bb = bx * bx + by * by + bz * bz
        t = min(max((px * bx + py * by + pz * bz) / bb, 0.0), 1.0) if bb > 0.0 else 0.0
        return math.sqrt((px - t * bx) ** 2 + (py - t * by) ** 2 + (pz - t * bz) ** 2) - prm[6]
    return _trilinear(grid, x / dx, y / dy, (z - z0) / dz - 0.5)


@numba.njit(cache=True)
def _base_at(codes, params, stack, heights, norms, grid, dx, dy, z0, dz, x, y, z):
    """f (m) of a compiled base at (x, y, z): its postfix program on ``stack``."""
    top = 0
    for i in range(codes.size):
        code = codes[i]
        if code == UNION:
            top -= 1
            stack[top - 1] = min(stack[top - 1], stack[top])
        elif code == DIFFERENCE:
            top -= 1
            stack[top - 1] = max(stack[top - 1], -stack[top])
        else:
            stack[top] = _primitive(code, params[i], heights, norms, grid, dx, dy, z0, dz, x, y, z)
            top += 1
    return stack[0]


@numba.njit(cache=True, inline="always")
def _metaball(balls, j, x, y, z):
    """Metaball j of the table (module docstring) at (x, y, z) (m)."""
    px, py, pz = x - balls[j, BALL_X], y - balls[j, BALL_Y], z - balls[j, BALL_Z]
    radius = balls[j, BALL_R]
    s = (px * balls[j, BALL_NX] + py * balls[j, BALL_NY] + pz * balls[j, BALL_NZ]) / radius
    fade = min(1.0, 2.0 - 2.0 * s) if s >= 0.0 else min(1.0, 2.0 * (s + BEHIND + 0.5))
    if fade <= 0.0:
        return 0.0
    t2 = px * px + py * py + pz * pz - (s * radius) ** 2
    t = math.sqrt(t2) if t2 > 0.0 else 0.0
    return balls[j, BALL_A] * (1.0 - t / radius) * fade if t < radius else 0.0


@numba.njit(cache=True)
def _balls_at(balls, x, y, z):
    """Σ of the metaballs at (x, y, z) (m), in table order."""
    total = 0.0
    for j in range(balls.shape[0]):
        total += _metaball(balls, j, x, y, z)
    return total


@numba.njit(cache=True, parallel=True)
def evaluate_points(codes, params, depth, heights, norms, grid, dx, dy, z0, dz, balls, points):
    """The tree's f (m): base + Σ metaballs at points float64[n, 3] (m): float64[n]."""
    n = points.shape[0]
    out = np.empty(n)
    block = 256
    for b in numba.prange((n + block - 1) // block):
        stack = np.empty(depth)
        for i in range(b * block, min(n, (b + 1) * block)):
            x, y, z = points[i, 0], points[i, 1], points[i, 2]
            out[i] = _base_at(codes, params, stack, heights, norms, grid, dx, dy, z0, dz, x, y, z) \
                + _balls_at(balls, x, y, z)
    return out


@numba.njit(cache=True, parallel=True)
def sample_nodes(codes, params, depth, heights, norms, grid, dx, dy, z0, dz, shape):
    """A base's f (m) at the nodes (column·dx, row·dy, z0 + (layer + ½)·dz) of ``shape``
    (rows, columns, layers): float64[shape]."""
    ny, nx, nz = shape
    out = np.empty((ny, nx, nz))
    for r in numba.prange(ny):
        stack = np.empty(depth)
        for c in range(nx):
            for k in range(nz):
                out[r, c, k] = _base_at(codes, params, stack, heights, norms, grid, dx, dy, z0, dz,
                                        c * dx, r * dy, z0 + (k + 0.5) * dz)
    return out


@numba.njit(cache=True)
def _value_gradient(g, x, y, z, dx, dy, z0, dz):
    """Trilinear g at (x, y, z) (m) and its gradient (1/m of g's unit): (g, ∂x, ∂y, ∂z); a
    derivative across a clamped border is 0."""
    ny, nx, nz = g.shape
    c, fx = cell_frac(x / dx, nx)
    r, fy = cell_frac(y / dy, ny)
    k, fz = cell_frac((z - z0) / dz - 0.5, nz)
    c1, r1, k1 = min(c + 1, nx - 1), min(r + 1, ny - 1), min(k + 1, nz - 1)
    a0 = g[r, c, k] * (1.0 - fx) + g[r, c1, k] * fx
    a1 = g[r1, c, k] * (1.0 - fx) + g[r1, c1, k] * fx
    b0 = g[r, c, k1] * (1.0 - fx) + g[r, c1, k1] * fx
    b1 = g[r1, c, k1] * (1.0 - fx) + g[r1, c1, k1] * fx
    lo, hi = a0 * (1.0 - fy) + a1 * fy, b0 * (1.0 - fy) + b1 * fy
    ddx = ((g[r, c1, k] - g[r, c, k]) * (1.0 - fy) + (g[r1, c1, k] - g[r1, c, k]) * fy) * (1.0 - fz) \
        + ((g[r, c1, k1] - g[r, c, k1]) * (1.0 - fy) + (g[r1, c1, k1] - g[r1, c, k1]) * fy) * fz
    ddy = (a1 - a0) * (1.0 - fz) + (b1 - b0) * fz
    return (lo * (1.0 - fz) + hi * fz, ddx / dx if c1 > c else 0.0, ddy / dy if r1 > r else 0.0,
            (hi - lo) / dz if k1 > k else 0.0)


@numba.njit(cache=True, inline="always")
def _span(centre, d, radius):
    """(low, high) (m) along one axis of a cylinder of radius R along the unit vector whose
    component on that axis is d, from (``BEHIND`` + ½)·R behind ``centre`` to R ahead."""
    across = radius * math.sqrt(max(0.0, 1.0 - d * d))
    ahead, behind = centre + radius * d, centre - (BEHIND + 0.5) * radius * d
    return min(ahead, behind) - across, max(ahead, behind) + across


@numba.njit(cache=True)
def _reach(shape, dx, dy, z0, dz, balls, j):
    """Index bounds (r0, r1, c0, c1, k0, k1), inclusive, of the nodes metaball j may reach
    (the box around its support, ``_span``)."""
    ny, nx, nz = shape
    radius = balls[j, BALL_R]
    x_lo, x_hi = _span(balls[j, BALL_X], balls[j, BALL_NX], radius)
    y_lo, y_hi = _span(balls[j, BALL_Y], balls[j, BALL_NY], radius)
    z_lo, z_hi = _span(balls[j, BALL_Z] - z0, balls[j, BALL_NZ], radius)
    return (max(0, int(math.ceil(y_lo / dy))), min(ny - 1, int(math.floor(y_hi / dy))),
            max(0, int(math.ceil(x_lo / dx))), min(nx - 1, int(math.floor(x_hi / dx))),
            max(0, int(math.ceil(z_lo / dz - 0.5))), min(nz - 1, int(math.floor(z_hi / dz - 0.5))))


@numba.njit(cache=True)
def _splat(cache, dx, dy, z0, dz, balls, j, scale):
    """Add ``scale`` times metaball j of the table to the node values it reaches."""
    r0, r1, c0, c1, k0, k1 = _reach(cache.shape, dx, dy, z0, dz, balls, j)
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            for k in range(k0, k1 + 1):
                cache[r, c, k] += scale * _metaball(balls, j, c * dx, r * dy, z0 + (k + 0.5) * dz)


@numba.njit(cache=True)
def _column_ground(f, k_lo, k_hi, dz):
    """Length (m) of ground (f < 0) of a column's values f between layers k_lo and k_hi: f
    linear between the layers, and the half layer below the bottom node or above the top one
    (when the range reaches it) taking the sign of that node."""
    nz = f.size
    total = 0.0
    if k_lo == 0 and f[0] < 0.0:
        total += 0.5 * dz
    if k_hi == nz - 1 and f[nz - 1] < 0.0:
        total += 0.5 * dz
    for k in range(k_lo, k_hi):
        a, b = f[k], f[k + 1]
        if a < 0.0 and b < 0.0:
            total += dz
        elif a < 0.0 <= b:
            total += dz * a / (a - b)
        elif b < 0.0 <= a:
            total += dz * b / (b - a)
    return total


@numba.njit(cache=True)
def _ground_near(cache, valid, bounds, dz):
    """Ground length (m) summed over the valid columns of ``bounds`` (r0, r1, c0, c1, k0, k1),
    over the layers one beyond k0 and k1: all that changes when the nodes within change."""
    r0, r1, c0, c1, k0, k1 = bounds
    nz = cache.shape[2]
    total = 0.0
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            if valid[r, c]:
                total += _column_ground(cache[r, c], max(k0 - 1, 0), min(k1 + 1, nz - 1), dz)
    return total


@numba.njit(cache=True)
def _column_crossing(cache, x, y, z, z0, dz, dx, dy, upwards):
    """The elevation (m) of the first zero crossing of the trilinear cache above (``upwards``)
    or below (x, y, z), f being linear in z between the node layers of a column; NaN when
    the column has none that way."""
    nz = cache.shape[2]
    z_prev = min(max(z, z0 + 0.5 * dz), z0 + (nz - 0.5) * dz)
    f_prev = _trilinear(cache, x / dx, y / dy, (z_prev - z0) / dz - 0.5)
    k = int(math.floor((z_prev - z0) / dz - 0.5)) + (1 if upwards else 0)
    step = 1 if upwards else -1
    while 0 <= k < nz:
        zk = z0 + (k + 0.5) * dz
        fk = _trilinear(cache, x / dx, y / dy, float(k))
        if (fk >= 0.0) != (f_prev >= 0.0):
            return z_prev + (zk - z_prev) * f_prev / (f_prev - fk)
        z_prev, f_prev = zk, fk
        k += step
    return math.nan


@numba.njit(cache=True)
def _onto_surface(cache, dx, dy, z0, dz, x, y, z, reach):
    """The point of the cache's 0-level near (x, y, z) (m) and the unit normal ∇f/‖∇f‖ there
    (straight up where ∇f vanishes): a point in the air more than ``reach`` (m) above the
    ground first goes straight down onto the crossing below it; then Newton steps along ∇f
    (at most ``NEWTON_STEPS`` of one node spacing). When they do not end on the surface (a
    point deep under a pile of deposits, where f need not grow upwards) the point goes up
    (from the ground) or down (from the air) its column to the first crossing instead. A
    point whose column has none keeps its place. Returns (x, y, z, n_x, n_y, n_z)."""
    spacing = min(dx, dy, dz)
    f = _trilinear(cache, x / dx, y / dy, (z - z0) / dz - 0.5)
    if f > reach:
        down = _column_crossing(cache, x, y, z, z0, dz, dx, dy, False)
        if math.isnan(down):
            return x, y, z, 0.0, 0.0, 1.0
        z = down
    start_x, start_y, start_z, start_f = x, y, z, f
    for step in range(NEWTON_STEPS + 1):
        f, gx, gy, gz = _value_gradient(cache, x, y, z, dx, dy, z0, dz)
        g2 = gx * gx + gy * gy + gz * gz
        if abs(f) <= NEWTON_TOLERANCE * spacing or g2 == 0.0 or step == NEWTON_STEPS:
            break
        s = f / g2
        move = abs(s) * math.sqrt(g2)
        if move > NEWTON_MOVE * spacing:
            s *= NEWTON_MOVE * spacing / move
        x, y, z = x - s * gx, y - s * gy, z - s * gz
    if abs(f) > NEWTON_MISS * spacing:
        crossing = _column_crossing(cache, start_x, start_y, start_z, z0, dz, dx, dy, start_f < 0.0)
        if not math.isnan(crossing):
            x, y, z = start_x, start_y, crossing
            f, gx, gy, gz = _value_gradient(cache, x, y, z, dx, dy, z0, dz)
            g2 = gx * gx + gy * gy + gz * gz
    if g2 == 0.0:
        return x, y, z, 0.0, 0.0, 1.0
    norm = math.sqrt(g2)
    return x, y, z, gx / norm, gy / norm, gz / norm


@numba.njit(cache=True)
def place_changes(cache, valid, dx, dy, z0, dz, xs, ys, zs, qs, rs):
    """Turn changes of volume Q (m³, > 0 deposits) at (x, y, z) (m) with radii R (m) into
    metaballs, in order: each is put onto the 0-level of the cache as it stands
    (``_onto_surface``, from R above), given d̂ = ± the normal there and the radius R widened
    to ``MIN_RADIUS`` node spacings and to |a| = ``U_MAX``·R, added to the cache with a =
    −3Q/(πR²), then rescaled (``SIZE_STEPS`` secant steps, by at most ``SIZE_CAP``) until the
    ground of the ``valid`` columns changed by Q (module docstring).
    Returns the metaballs (columns ``BALL_*``): float64[n, BALL_COLUMNS]."""
    balls = np.empty((qs.size, BALL_COLUMNS))
    smallest = MIN_RADIUS * max(dx, dy, dz)
    area = dx * dy
    for j in range(qs.size):
        q = qs[j]
        radius = max(rs[j], smallest, (3.0 * abs(q) / (math.pi * U_MAX)) ** (1.0 / 3.0))
        x, y, z, nx_, ny_, nz_ = _onto_surface(cache, dx, dy, z0, dz, xs[j], ys[j], zs[j], radius)
        balls[j, BALL_X], balls[j, BALL_Y], balls[j, BALL_Z] = x, y, z
        balls[j, BALL_R], balls[j, BALL_A] = radius, -3.0 * q / (math.pi * radius * radius)
        ahead = 1.0 if q > 0.0 else -1.0
        balls[j, BALL_NX], balls[j, BALL_NY], balls[j, BALL_NZ] = ahead * nx_, ahead * ny_, ahead * nz_
        bounds = _reach(cache.shape, dx, dy, z0, dz, balls, j)
        before = _ground_near(cache, valid, bounds, dz)
        _splat(cache, dx, dy, z0, dz, balls, j, 1.0)
        first = balls[j, BALL_A]
        for _ in range(SIZE_STEPS):
            moved = (_ground_near(cache, valid, bounds, dz) - before) * area
            if moved * q <= 0.0 or abs(moved - q) <= SIZE_TOLERANCE * abs(q):
                break
            scale = min(q / moved, SIZE_CAP * first / balls[j, BALL_A], radius / abs(balls[j, BALL_A]))
            if scale == 1.0:
                break
            _splat(cache, dx, dy, z0, dz, balls, j, scale - 1.0)
            balls[j, BALL_A] *= scale
    return balls


@numba.njit(cache=True)
def add_metaballs(cache, dx, dy, z0, dz, balls):
    """Add metaballs (columns ``BALL_*``) to the node values ``cache`` in place."""
    for j in range(balls.shape[0]):
        _splat(cache, dx, dy, z0, dz, balls, j, 1.0)


@numba.njit(cache=True, parallel=True)
def ground_volume(cache, valid, dz):
    """Length (m) of ground (f < 0) of each row's valid columns, summed per row
    (``_column_ground`` over whole columns): float64[rows]; × dx·dy gives the volume (m³)."""
    ny, nx, nz = cache.shape
    out = np.zeros(ny)
    for r in numba.prange(ny):
        total = 0.0
        for c in range(nx):
            if valid[r, c]:
                total += _column_ground(cache[r, c], 0, nz - 1, dz)
        out[r] = total
    return out
