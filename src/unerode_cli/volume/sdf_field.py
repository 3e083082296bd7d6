"""Implicit terrains (003 §4.3): ``ImplicitField``, the ground where a signed distance function f
(m) is negative (f < 0 in the ground, f > 0 in the air, the ground's surface at f = 0, 003's
sign), whose detachment and deposition add metaballs to f (003 Eq. 11). Its scene is a
``sdf_shapes`` tree compiled into a ``Base``; its metaballs and their placement are described in
``sdf_kernels``. Nothing here knows about particles; import it where numba may load (its kernels
compile on first use).

Cache: f at the voxel centres of the geometry (the nodes), kept up to date — the base sampled
once, each metaball added to the nodes it reaches — and read trilinearly by the tracer.
When ``flatten_every`` metaballs are pending the tree is flattened: the base becomes the cache
(a trilinear grid) and the list empties, which bounds memory and the cost of an exact
evaluation. Flattening adds the trilinear interpolation error of f between nodes, at most
L·D/2 for f of slope at most L (D the diagonal of a node cell): none where f is linear (a
plane; a heightfield's surface along z), at most √5·|a|·D/(2R) within a metaball's reach (its
slope is at most |a|/R across d̂ and 2|a|/R along it) and about D²κ/8 on a surface of
curvature κ (a sphere: κ = 1/r).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from unerode_cli.volume.sdf_kernels import (
    BALL_COLUMNS,
    BALL_NX,
    BALL_R,
    add_metaballs,
    evaluate_points,
    ground_volume,
    place_changes,
    sample_nodes,
)
from unerode_cli.volume.sdf_shapes import DIFFERENCE, GRID, N_PARAMS, UNION, Shape, uses_surface
from unerode_cli.volume.voxels import DensityVoxels, VoxelGeometry

#: Metaballs pending before the tree is flattened into the cache (8 float64 each: 8 MiB).
FLATTEN_EVERY = 2**17
#: Step of the central differences of ``ImplicitField.normals``, in node spacings.
NORMAL_STEP = 1e-4


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

    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray,
              valid: np.ndarray | None = None) -> None:
        """Changes of volume Q (m³, > 0 deposits) at points (x, y, z) (m) with radii R (m), in
        order: metaballs put on the surface and sized by ``place_changes`` (``sdf_kernels``)
        so that the ground of the ``valid`` columns (default: all) changes by Q."""
        values = [np.ascontiguousarray(v, dtype=np.float64).reshape(-1) for v in (x, y, z, q, radius)]
        keep = values[3] != 0.0
        x, y, z, q, radius = (v[keep] for v in values)
        if not (np.isfinite(np.concatenate([x, y, z, q, radius])).all() and (radius > 0).all()):
            raise ValueError("changes need finite positions and volumes and radii > 0 m")
        columns = np.ones(self.geometry.shape[:2], bool) if valid is None else np.asarray(valid, bool)
        self._append(place_changes(self.cache, columns, *self._frame(), x, y, z, q, radius))

    def add_metaballs(self, balls: np.ndarray) -> None:
        """Add metaballs float64[m, BALL_COLUMNS] (centre, R, a in m, unit direction d̂; columns
        ``BALL_*``) as they are."""
        table = np.ascontiguousarray(balls, dtype=np.float64).reshape(-1, BALL_COLUMNS)
        normals = np.linalg.norm(table[:, BALL_NX:], axis=1)
        if not (np.isfinite(table).all() and (table[:, BALL_R] > 0).all() and np.allclose(normals, 1.0)):
            raise ValueError("metaballs need finite centres and amplitudes, radii > 0 m and unit directions")
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
