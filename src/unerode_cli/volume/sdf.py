"""Implicit terrains (003 §4.3): the ground is where a signed distance function f is negative
(f in m; f < 0 in the ground, f > 0 in the air, the ground's surface at f = 0, 003's sign),
and detachment and deposition add metaballs to f (003 Eq. 11). Nothing here knows about
particles; import it where numba may load (it compiles its kernels on first use).

Frame: x = column·dx (m, east), y = row·dy (m, south), z the elevation (m), with the columns of
a ``volume.voxels.VoxelGeometry``; ``Shape.framed`` moves a scene from map coordinates into it.

Base: a scene of primitives — the surface of a heightfield, the half-space under a plane, a
box, a sphere, a capsule — combined by union (min) and difference (max(a, −b)), compiled into
a postfix program that numba evaluates. A heightfield's surface is f = (z − h(x, y))/n(x, y),
h bilinear between the column centres and n = √(1 + |∇h|²) (central differences at the
centres, bilinear between): the normaliser makes f the distance to the surface where it is
locally planar (z − h alone overstates it by n on a slope, and a metaball would then change
the volume by Q/n instead of Q); the 0-level is h whatever n.

Metaballs (003 Eq. 11): a change of volume Q (m³, > 0 deposits) at a surface point c with
radius R adds a metaball of compact support, m(p) = a·max(0, 1 − t/R)·w(s/R), with s = n̂·(p − c)
the distance along the surface's outward normal n̂ at c, t = ‖p − c − s·n̂‖ the distance across
it and w(σ) = min(1, max(0, 2 − 2|σ|)) (1 within R/2 of the tangent plane, 0 beyond R). The
composition is the sum f̃ = f + Σ m, so eroding then depositing the same metaball restores f
(to rounding). Within R/2 of the surface m is constant along the normal, so on a plane the
surface moves by exactly a·(1 − t/R): 003 Eq. 9's cone profile (1 − d/R, Eq. 11) laid on the
surface, lifting ∫₀ᴿ(1 − t/R)·2πt dt = πR²/3 per metre of a, hence a = −3Q/(πR²) (m). This
departs from 003 twice, for the volume to be Q: Eq. 11 (its appendix, Eq. 15–17) scales the
cone so that its *volume* integral is Q (λ = 3Q/(πR³)), which suits a density (voxels, Eq. 13)
but not a distance, whose surface moves by what is added to it; and Eq. 11's cone is round
(d = ‖p − c‖), which lifts a plane by less than a near c (the lift t solves t = a(1 − √(ρ² + t²)/R))
and, sampled on nodes a radius apart along z, loses a quarter of its volume to the linear
interpolation between them, where m constant along the normal loses nothing. A change with
|a| > R/2 is spread over the radius at which |a| = R/2, and a radius below ``MIN_RADIUS`` node
spacings is widened to it (the cache cannot hold a narrower cone: at one spacing about 6 % of
its volume falls between the nodes, at 1.5 under 0.1 %; on a heightfield a footprint narrower
than a cell likewise goes to the nearest cell). A metaball moves the surface by less than R/2
along n̂, and a pile of narrow ones would lose what its steep flanks leave outside that band.
Changes are placed in order, each put on
the surface as the ones before left it (``place_changes``): all the impacts of an iteration
are traced on one frozen terrain, and a change left above or below the surface would move less
matter. Off a plane the lift differs from πR²|a|/3: the surface moves by m/|∇f| along its own
normal, over an area 1/cos θ times its projection on the disc, so the volume is
∫ a(1 − t/R)/(∇f·n̂) dA over the disc — on a sphere of curvature κ about 1 + 0.15 (κR)² times
the plane's (4.7 % for κR = 0.56), and more over the bumps earlier metaballs left. a is
divided by that factor, measured on the cache's surface under the disc (``_lift_factor``). The
volume change is then Q up to higher orders of a/R and of the surface's slopes within R.

Cache: f at the voxel centres of the geometry (the nodes), kept up to date — the base sampled
once, each metaball added to the nodes it reaches — and read trilinearly by the tracer.
When ``flatten_every`` metaballs are pending the tree is flattened: the base becomes the cache
(a trilinear grid) and the list empties, which bounds memory and the cost of an exact
evaluation. Flattening adds the trilinear interpolation error of f between nodes, at most
L·D/2 for f of slope at most L (D the diagonal of a node cell): none where f is linear (a
plane; a heightfield's surface along z), at most √5·|a|·D/(2R) within a metaball's reach (its
slope is at most |a|/R across the normal and 2|a|/R along it) and about D²κ/8 on a surface of
curvature κ (a sphere: κ = 1/r).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from unerode_cli.volume.voxels import DensityVoxels, VoxelGeometry

Vec3 = tuple[float, float, float]
#: Opcodes of a compiled program and the parameters each primitive takes (row of ``params``).
SURFACE, PLANE, BOX, SPHERE, CAPSULE, GRID, UNION, DIFFERENCE = range(8)
N_PARAMS = 7
#: Metaballs pending before the tree is flattened into the cache (8 float64 each: 8 MiB).
FLATTEN_EVERY = 2**17
#: Largest |a|/R = 3|Q|/(πR³) of a metaball; a larger change is spread over a wider one.
U_MAX = 0.5
#: Smallest metaball radius, in node spacings (the largest of dx, dy, dz).
MIN_RADIUS = 1.5
#: Sampling of the surface under a metaball (``_lift_factor``): rings, points per ring, Newton
#: steps onto the surface, and the smallest ∇f·n̂ taken (a surface folded within R).
LIFT_RINGS = 3
LIFT_SPOKES = 6
LIFT_STEPS = 2
LIFT_MIN_SLOPE = 0.25
#: Newton steps that put a change on the surface, the longest move of one (node spacings) and
#: the |f| at which a point is on the surface (node spacings).
NEWTON_STEPS = 4
NEWTON_MOVE = 1.0
NEWTON_TOLERANCE = 1e-6
#: Columns of the metaball table: centre (m), radius R (m), amplitude a (m), unit normal.
BALL_X, BALL_Y, BALL_Z, BALL_R, BALL_A, BALL_NX, BALL_NY, BALL_NZ = range(8)
BALL_COLUMNS = 8
#: Step of the central differences of ``ImplicitField.normals``, in node spacings.
NORMAL_STEP = 1e-4


def _framed_point(p: Vec3, x0: float, y0: float) -> Vec3:
    return (p[0] - x0, y0 - p[1], p[2])


@dataclass(frozen=True)
class Surface:
    """The ground under the heightfield the field is built with (the DEM): f = (z − h)/n."""

    def framed(self, x0: float, y0: float) -> Surface:
        return self

    def z_range(self) -> tuple[float, float] | None:
        return None

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(SURFACE, ())]


@dataclass(frozen=True)
class Plane:
    """The half-space below the plane through ``point`` (m) with ``normal`` pointing into the
    air: f = n̂·(p − point)."""

    point: Vec3
    normal: Vec3

    def __post_init__(self) -> None:
        if not math.hypot(*self.normal) > 0:
            raise ValueError("a plane's normal must not be zero")

    def framed(self, x0: float, y0: float) -> Plane:
        return Plane(_framed_point(self.point, x0, y0), (self.normal[0], -self.normal[1], self.normal[2]))

    def z_range(self) -> tuple[float, float] | None:
        return None

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        n = np.asarray(self.normal, float) / math.hypot(*self.normal)
        return [(PLANE, (*self.point, *n.tolist()))]


@dataclass(frozen=True)
class Box:
    """An axis-aligned box of ``size`` (m, full extents) around ``centre`` (m)."""

    centre: Vec3
    size: Vec3

    def __post_init__(self) -> None:
        if not min(self.size) > 0:
            raise ValueError(f"a box's sizes must be > 0 m, got {self.size}")

    def framed(self, x0: float, y0: float) -> Box:
        return Box(_framed_point(self.centre, x0, y0), self.size)

    def z_range(self) -> tuple[float, float] | None:
        return self.centre[2] - 0.5 * self.size[2], self.centre[2] + 0.5 * self.size[2]

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(BOX, (*self.centre, *(0.5 * s for s in self.size)))]


@dataclass(frozen=True)
class Sphere:
    """A ball of ``radius`` (m) around ``centre`` (m)."""

    centre: Vec3
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ValueError(f"a sphere's radius must be > 0 m, got {self.radius}")

    def framed(self, x0: float, y0: float) -> Sphere:
        return Sphere(_framed_point(self.centre, x0, y0), self.radius)

    def z_range(self) -> tuple[float, float] | None:
        return self.centre[2] - self.radius, self.centre[2] + self.radius

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(SPHERE, (*self.centre, self.radius))]


@dataclass(frozen=True)
class Capsule:
    """The points within ``radius`` (m) of the segment from ``a`` to ``b`` (m)."""

    a: Vec3
    b: Vec3
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ValueError(f"a capsule's radius must be > 0 m, got {self.radius}")

    def framed(self, x0: float, y0: float) -> Capsule:
        return Capsule(_framed_point(self.a, x0, y0), _framed_point(self.b, x0, y0), self.radius)

    def z_range(self) -> tuple[float, float] | None:
        return min(self.a[2], self.b[2]) - self.radius, max(self.a[2], self.b[2]) + self.radius

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return [(CAPSULE, (*self.a, *self.b, self.radius))]


@dataclass(frozen=True)
class Union:
    """The union of ``shapes`` (f = min)."""

    shapes: tuple[Shape, ...]

    def framed(self, x0: float, y0: float) -> Union:
        return Union(tuple(s.framed(x0, y0) for s in self.shapes))

    def z_range(self) -> tuple[float, float] | None:
        ranges = [r for s in self.shapes if (r := s.z_range()) is not None]
        return (min(r[0] for r in ranges), max(r[1] for r in ranges)) if ranges else None

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return _fold(self.shapes, UNION)


@dataclass(frozen=True)
class Difference:
    """The first of ``shapes`` minus the others (f = max(a, −b))."""

    shapes: tuple[Shape, ...]

    def framed(self, x0: float, y0: float) -> Difference:
        return Difference(tuple(s.framed(x0, y0) for s in self.shapes))

    def z_range(self) -> tuple[float, float] | None:
        return self.shapes[0].z_range()

    def program(self) -> list[tuple[int, tuple[float, ...]]]:
        return _fold(self.shapes, DIFFERENCE)


Shape = Surface | Plane | Box | Sphere | Capsule | Union | Difference


def _fold(shapes: tuple[Shape, ...], operation: int) -> list[tuple[int, tuple[float, ...]]]:
    if not shapes:
        raise ValueError("a union or difference needs at least one shape")
    out = shapes[0].program()
    for shape in shapes[1:]:
        out += [*shape.program(), (operation, ())]
    return out


def uses_surface(shape: Shape) -> bool:
    """Whether the scene contains the heightfield's surface."""
    if isinstance(shape, Union | Difference):
        return any(uses_surface(s) for s in shape.shapes)
    return isinstance(shape, Surface)


@dataclass(frozen=True)
class Base:
    """A compiled base: postfix ``codes`` (int64[n]) and ``params`` (float64[n, N_PARAMS]), the
    stack ``depth`` it needs, the heightfield h and normaliser n of ``SURFACE`` (float64[rows,
    columns], empty without) and the node values of ``GRID`` (float64[rows, columns, layers],
    empty without)."""

    codes: np.ndarray
    params: np.ndarray
    depth: int
    heights: np.ndarray
    norms: np.ndarray
    grid: np.ndarray

    @classmethod
    def of_shape(cls, shape: Shape, heights: np.ndarray | None, dx: float, dy: float) -> Base:
        """The base of a scene (in the field's frame) over the heightfield ``heights`` (m, one
        per column; needed when the scene has the surface)."""
        ops = shape.program()
        codes = np.array([code for code, _ in ops], np.int64)
        params = np.zeros((len(ops), N_PARAMS))
        for row, (_, values) in enumerate(ops):
            params[row, : len(values)] = values
        depth, peak = 0, 0
        for code in codes:
            depth += -1 if code in (UNION, DIFFERENCE) else 1
            peak = max(peak, depth)
        if uses_surface(shape):
            if heights is None:
                raise ValueError("the scene has the heightfield's surface and no heightfield is given")
            h = np.ascontiguousarray(heights, dtype=np.float64)
            gy, gx = np.gradient(h, dy, dx) if min(h.shape) > 1 else (np.zeros_like(h), np.zeros_like(h))
            norms = np.sqrt(1.0 + gx * gx + gy * gy)
        else:
            h = norms = np.zeros((0, 0))
        return cls(codes, params, peak, h, norms, np.zeros((0, 0, 0)))

    @classmethod
    def of_grid(cls, values: np.ndarray) -> Base:
        """A flattened base: trilinear between the given node values (copied)."""
        return cls(np.array([GRID], np.int64), np.zeros((1, N_PARAMS)), 1, np.zeros((0, 0)), np.zeros((0, 0)),
                   np.array(values, dtype=np.float64, order="C"))

    def arguments(self) -> tuple:
        return self.codes, self.params, self.depth, self.heights, self.norms, self.grid


@numba.njit(cache=True, inline="always")
def _node_frac(s, n):
    """Lower node index and fraction of a node coordinate ``s`` (nodes at integers), clamped
    to the n nodes."""
    s = min(max(s, 0.0), n - 1.0)
    i = min(int(s), n - 2) if n > 1 else 0
    return i, s - i


@numba.njit(cache=True)
def _bilinear(a, col, row):
    """Bilinear a[row, column] at node coordinates (col, row), clamped at the border."""
    ny, nx = a.shape
    c, fx = _node_frac(col, nx)
    r, fy = _node_frac(row, ny)
    c1, r1 = min(c + 1, nx - 1), min(r + 1, ny - 1)
    return (a[r, c] * (1.0 - fx) + a[r, c1] * fx) * (1.0 - fy) + (a[r1, c] * (1.0 - fx) + a[r1, c1] * fx) * fy


@numba.njit(cache=True)
def _trilinear(g, col, row, layer):
    """Trilinear g[row, column, layer] at node coordinates (col, row, layer), clamped."""
    ny, nx, nz = g.shape
    c, fx = _node_frac(col, nx)
    r, fy = _node_frac(row, ny)
    k, fz = _node_frac(layer, nz)
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
        return (z - _bilinear(heights, col, row)) / _bilinear(norms, col, row)
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
    s = px * balls[j, BALL_NX] + py * balls[j, BALL_NY] + pz * balls[j, BALL_NZ]
    fade = min(1.0, 2.0 - 2.0 * abs(s) / radius)
    if fade <= 0.0:
        return 0.0
    t2 = px * px + py * py + pz * pz - s * s
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
    c, fx = _node_frac(x / dx, nx)
    r, fy = _node_frac(y / dy, ny)
    k, fz = _node_frac((z - z0) / dz - 0.5, nz)
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


@numba.njit(cache=True)
def _splat(cache, dx, dy, z0, dz, balls, j):
    """Add metaball j of the table to the node values, over the box around its support (a
    cylinder of radius R and half-height R along n̂: R·(√(1 − n_i²) + |n_i|) along axis i)."""
    ny, nx, nz = cache.shape
    x, y, z, radius = balls[j, BALL_X], balls[j, BALL_Y], balls[j, BALL_Z], balls[j, BALL_R]
    ex = radius * (math.sqrt(max(0.0, 1.0 - balls[j, BALL_NX] ** 2)) + abs(balls[j, BALL_NX]))
    ey = radius * (math.sqrt(max(0.0, 1.0 - balls[j, BALL_NY] ** 2)) + abs(balls[j, BALL_NY]))
    ez = radius * (math.sqrt(max(0.0, 1.0 - balls[j, BALL_NZ] ** 2)) + abs(balls[j, BALL_NZ]))
    r0, r1 = max(0, int(math.ceil((y - ey) / dy))), min(ny - 1, int(math.floor((y + ey) / dy)))
    c0, c1 = max(0, int(math.ceil((x - ex) / dx))), min(nx - 1, int(math.floor((x + ex) / dx)))
    kk = (z - z0) / dz - 0.5
    k0, k1 = max(0, int(math.ceil(kk - ez / dz))), min(nz - 1, int(math.floor(kk + ez / dz)))
    for r in range(r0, r1 + 1):
        for c in range(c0, c1 + 1):
            for k in range(k0, k1 + 1):
                cache[r, c, k] += _metaball(balls, j, c * dx, r * dy, z0 + (k + 0.5) * dz)


@numba.njit(cache=True)
def _onto_surface(cache, dx, dy, z0, dz, x, y, z, reach):
    """The point of the cache's 0-level near (x, y, z) (m): a point in the air more than
    ``reach`` (m) above the ground first goes straight down onto the highest crossing below it
    (f is linear in z between the node layers of a column), then Newton steps along ∇f (at most
    ``NEWTON_STEPS`` of one node spacing). A point with no ground below keeps its place.
    Returns (x, y, z, n_x, n_y, n_z), n̂ = ∇f/‖∇f‖ there (straight up where ∇f vanishes)."""
    nz = cache.shape[2]
    spacing = min(dx, dy, dz)
    f = _trilinear(cache, x / dx, y / dy, (z - z0) / dz - 0.5)
    if f > reach:
        z_prev = min(z, z0 + (nz - 0.5) * dz)
        f_prev = _trilinear(cache, x / dx, y / dy, (z_prev - z0) / dz - 0.5)
        grounded = False
        for k in range(min(int(math.floor((z_prev - z0) / dz - 0.5)), nz - 1), -1, -1):
            zk = z0 + (k + 0.5) * dz
            fk = _trilinear(cache, x / dx, y / dy, float(k))
            if fk < 0.0:
                z = z_prev + (zk - z_prev) * f_prev / (f_prev - fk)
                grounded = True
                break
            z_prev, f_prev = zk, fk
        if not grounded:
            return x, y, z, 0.0, 0.0, 1.0
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
    if g2 == 0.0:
        return x, y, z, 0.0, 0.0, 1.0
    norm = math.sqrt(g2)
    return x, y, z, gx / norm, gy / norm, gz / norm


@numba.njit(cache=True)
def _lift_factor(cache, dx, dy, z0, dz, x, y, z, nx_, ny_, nz_, radius):
    """The volume a metaball of unit amplitude at (x, y, z) with normal n̂ and radius R lifts
    on the cache's surface, over πR²/3 (its lift on the tangent plane): the mean of 1/(∇f·n̂)
    over the surface under the disc, weighted by the cone (module docstring). The surface is
    sampled on ``LIFT_RINGS`` rings of ``LIFT_SPOKES`` points, each moved along n̂ onto the
    0-level by ``LIFT_STEPS`` Newton steps (at most R/2 in all, the band the metaball lifts
    whole); ∇f·n̂ is kept above ``LIFT_MIN_SLOPE``."""
    if abs(nz_) < 0.9:  # a tangent basis (e1, e2) of the plane ⊥ n̂
        ax, ay, az = ny_, -nx_, 0.0
    else:
        ax, ay, az = 0.0, nz_, -ny_
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    e1x, e1y, e1z = ax / norm, ay / norm, az / norm
    e2x, e2y, e2z = ny_ * e1z - nz_ * e1y, nz_ * e1x - nx_ * e1z, nx_ * e1y - ny_ * e1x
    total = 0.0
    weights = 0.0
    for ring in range(LIFT_RINGS):
        t = (ring + 0.5) / LIFT_RINGS * radius
        weight = (1.0 - t / radius) * t
        for spoke in range(LIFT_SPOKES):
            angle = 2.0 * math.pi * (spoke + 0.5 * (ring % 2)) / LIFT_SPOKES
            cx, cy = t * math.cos(angle), t * math.sin(angle)
            px = x + cx * e1x + cy * e2x
            py = y + cx * e1y + cy * e2y
            pz = z + cx * e1z + cy * e2z
            slope = 1.0
            s = 0.0
            for _ in range(LIFT_STEPS):
                f, gx, gy, gz = _value_gradient(cache, px, py, pz, dx, dy, z0, dz)
                slope = max(gx * nx_ + gy * ny_ + gz * nz_, LIFT_MIN_SLOPE)
                step = min(max(-f / slope, -0.5 * radius - s), 0.5 * radius - s)
                s += step
                px, py, pz = px + step * nx_, py + step * ny_, pz + step * nz_
            total += weight / slope
            weights += weight
    return total / weights


@numba.njit(cache=True)
def place_changes(cache, dx, dy, z0, dz, xs, ys, zs, qs, rs):
    """Turn changes of volume Q (m³, > 0 deposits) at (x, y, z) (m) with radii R (m) into
    metaballs, in order: each is put onto the 0-level of the cache as it stands
    (``_onto_surface``, from R above), given the normal there, the radius R widened to
    ``MIN_RADIUS`` node spacings and to |a| = ``U_MAX``·R, and a = −3Q/(πR²) over the lift
    factor of the surface there (module docstring), and added to the cache.
    Returns the metaballs (columns ``BALL_*``): float64[n, BALL_COLUMNS]."""
    balls = np.empty((qs.size, BALL_COLUMNS))
    smallest = MIN_RADIUS * max(dx, dy, dz)
    for j in range(qs.size):
        radius = max(rs[j], smallest, (3.0 * abs(qs[j]) / (math.pi * U_MAX)) ** (1.0 / 3.0))
        x, y, z, nx_, ny_, nz_ = _onto_surface(cache, dx, dy, z0, dz, xs[j], ys[j], zs[j], radius)
        lift = _lift_factor(cache, dx, dy, z0, dz, x, y, z, nx_, ny_, nz_, radius)
        balls[j, BALL_X], balls[j, BALL_Y], balls[j, BALL_Z] = x, y, z
        balls[j, BALL_R], balls[j, BALL_A] = radius, -3.0 * qs[j] / (math.pi * radius * radius * lift)
        balls[j, BALL_NX], balls[j, BALL_NY], balls[j, BALL_NZ] = nx_, ny_, nz_
        _splat(cache, dx, dy, z0, dz, balls, j)
    return balls


@numba.njit(cache=True)
def add_metaballs(cache, dx, dy, z0, dz, balls):
    """Add metaballs (columns ``BALL_*``) to the node values ``cache`` in place."""
    for j in range(balls.shape[0]):
        _splat(cache, dx, dy, z0, dz, balls, j)


@numba.njit(cache=True, parallel=True)
def ground_volume(cache, valid, dz):
    """Length (m) of ground (f < 0) of each row's valid columns, summed per row: f linear
    between the node layers, the half layers below the bottom node and above the top one
    taking the sign of that node. float64[rows]; × dx·dy gives the volume (m³)."""
    ny, nx, nz = cache.shape
    out = np.zeros(ny)
    for r in numba.prange(ny):
        total = 0.0
        for c in range(nx):
            if not valid[r, c]:
                continue
            f = cache[r, c]
            total += 0.5 * dz * ((f[0] < 0.0) + (f[nz - 1] < 0.0))
            for k in range(nz - 1):
                a, b = f[k], f[k + 1]
                if a < 0.0 and b < 0.0:
                    total += dz
                elif a < 0.0 <= b:
                    total += dz * a / (a - b)
                elif b < 0.0 <= a:
                    total += dz * b / (b - a)
        out[r] = total
    return out


@dataclass
class ImplicitField:
    """An implicit terrain: f = base + Σ pending metaballs, and its node cache (module docstring).

    Args:
        geometry: the nodes of the cache (voxel centres; ``volume.voxels`` layout) and the frame.
        shape: the scene, in the frame (``Shape.framed``).
        heights: float64[rows, columns] heights (m) of the heightfield at the column centres,
            when the scene has its surface.
        flatten_every: pending metaballs that trigger a flattening.
    """

    geometry: VoxelGeometry
    shape: Shape
    heights: np.ndarray | None = None
    flatten_every: int = FLATTEN_EVERY
    base: Base = field(init=False)
    cache: np.ndarray = field(init=False)
    balls: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        if self.heights is not None and np.shape(self.heights) != self.geometry.shape[:2]:
            raise ValueError(f"the heights have shape {np.shape(self.heights)}, the columns "
                             f"{self.geometry.shape[:2]}")
        if int(self.flatten_every) != self.flatten_every or self.flatten_every < 1:
            raise ValueError(f"flatten_every must be an integer ≥ 1, got {self.flatten_every}")
        dx, dy, _ = self.geometry.size
        self.base = Base.of_shape(self.shape, self.heights, dx, dy)
        self.cache = sample_nodes(*self.base.arguments(), *self._frame(), self.geometry.shape)
        self.balls = np.zeros((0, BALL_COLUMNS))

    def _frame(self) -> tuple[float, float, float, float]:
        dx, dy, dz = self.geometry.size
        return dx, dy, self.geometry.origin[2], dz

    def copy(self) -> ImplicitField:
        new = ImplicitField.__new__(ImplicitField)
        new.geometry, new.shape, new.heights, new.flatten_every = (self.geometry, self.shape, self.heights,
                                                                   self.flatten_every)
        new.base = self.base
        new.cache = self.cache.copy()
        new.balls = self.balls.copy()
        return new

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """The exact f (m) of the tree at points float64[n, 3] (x, y, z in the frame, m)."""
        p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        return evaluate_points(*self.base.arguments(), *self._frame(), self.balls, p)

    def normals(self, points: np.ndarray) -> np.ndarray:
        """Unit outward normals ∇f/‖∇f‖ float64[n, 3] at points float64[n, 3] (m), the gradient
        by central differences of the exact f with a step of ``NORMAL_STEP`` node spacings
        (straight up where it vanishes)."""
        p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        step = NORMAL_STEP * min(self.geometry.size)
        offsets = np.repeat(np.eye(3) * step, 2, axis=0) * np.tile([[1.0], [-1.0]], (3, 1))
        values = self.evaluate((p[:, None, :] + offsets[None]).reshape(-1, 3)).reshape(-1, 3, 2)
        gradient = values[:, :, 0] - values[:, :, 1]
        norm = np.linalg.norm(gradient, axis=1, keepdims=True)
        up = np.broadcast_to([0.0, 0.0, 1.0], gradient.shape)
        return np.where(norm > 0, gradient / np.where(norm > 0, norm, 1.0), up)

    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray) -> None:
        """Changes of volume Q (m³, > 0 deposits) at points (x, y, z) (m) with radii R (m), in
        order: metaballs put on the surface and sized by ``place_changes`` (module docstring)."""
        values = [np.ascontiguousarray(v, dtype=np.float64).reshape(-1) for v in (x, y, z, q, radius)]
        keep = values[3] != 0.0
        x, y, z, q, radius = (v[keep] for v in values)
        if not (np.isfinite(np.concatenate([x, y, z, q, radius])).all() and (radius > 0).all()):
            raise ValueError("changes need finite positions and volumes and radii > 0 m")
        self._append(place_changes(self.cache, *self._frame(), x, y, z, q, radius))

    def add_metaballs(self, balls: np.ndarray) -> None:
        """Add metaballs float64[m, BALL_COLUMNS] (centre, R, a in m, unit normal; columns
        ``BALL_*``) as they are."""
        table = np.ascontiguousarray(balls, dtype=np.float64).reshape(-1, BALL_COLUMNS)
        normals = np.linalg.norm(table[:, BALL_NX:], axis=1)
        if not (np.isfinite(table).all() and (table[:, BALL_R] > 0).all() and np.allclose(normals, 1.0)):
            raise ValueError("metaballs need finite centres and amplitudes, radii > 0 m and unit normals")
        add_metaballs(self.cache, *self._frame(), table)
        self._append(table)

    def _append(self, balls: np.ndarray) -> None:
        """Keep the new metaballs in the tree, flattening it when enough are pending."""
        self.balls = np.concatenate([self.balls, balls])
        if len(self.balls) >= self.flatten_every:
            self.base = Base.of_grid(self.cache)
            self.balls = np.zeros((0, BALL_COLUMNS))

    def level(self) -> np.ndarray:
        """The cache as the tracer's float32 level −f/dz (> 0 in the ground, in voxels)."""
        return (self.cache * (-1.0 / self.geometry.size[2])).astype(np.float32)

    def top_surface(self) -> np.ndarray:
        """Elevation (m) of the highest zero crossing of each column of the cache (linear
        between nodes; the grid's bottom where a column has no ground): float64[rows, columns]."""
        from unerode_cli.volume.voxel_kernels import top_surface

        return top_surface(self.cache * (-1.0 / self.geometry.size[2]), self.geometry.origin[2],
                           self.geometry.size[2])

    def inside_volume(self, valid: np.ndarray) -> float:
        """Volume (m³) of the ground of the cache over the ``valid`` columns, f linear between
        the nodes of a column (``ground_volume``)."""
        dx, dy, dz = self.geometry.size
        return math.fsum(ground_volume(self.cache, np.asarray(valid, dtype=np.bool_), dz)) * dx * dy

    def density_voxels(self, valid: np.ndarray) -> DensityVoxels:
        """The cache as density voxels (003 §4.4) f_v = clip(−f/dz, −1, 1): the same 0-level
        where f changes by at most a voxel from node to node (an SDF on cubic voxels). Their
        matter Σ(1 + f_v)/2·V is the ground's volume where f grows by dz per layer along the
        columns (a flat surface) and near it on gentle slopes."""
        density = np.clip(self.cache / -self.geometry.size[2], -1.0, 1.0)
        return DensityVoxels(self.geometry, density, valid=valid)
