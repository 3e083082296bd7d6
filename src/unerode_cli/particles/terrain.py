"""Terrains that particles alter (003 §4), behind one small interface.

003 §4: a representation is eligible when one can (1) tell whether a particle intersects the
ground, (2) get the ground's normal there, and (3) apply a change Q at a point. ``Terrain``
holds those three; ``HeightfieldTerrain`` (003 §4.1) and ``LayeredTerrain`` (003 §4.2, material
stacks) implement them here, the voxel terrains (003 §4.4) in ``voxel_terrain``. The tracer
reads a frozen snapshot of the ground (``tracing_snapshot``): a heightfield of the ground
surface, or a voxel level, whose kind tells the tracer's ground queries which to read. The
numba kernels are imported on first use.

Coordinates are those of ``terrain_kernels``: x = column·dx (m), y = row·dy (m), z up (m).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from unerode_cli.grid import Grid


@dataclass(frozen=True)
class Material:
    """A ground material: erodibility K_ε (Pa^-a) and critical shear stress τ_c (Pa) of 003 Eq. 2."""

    name: str
    k_eps: float
    tau_c: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.k_eps) and np.isfinite(self.tau_c) and self.k_eps >= 0 and self.tau_c >= 0):
            raise ValueError(f"material {self.name!r} needs finite K_ε ≥ 0 and τ_c ≥ 0")


#: Ground kinds of a snapshot (``kernels.HEIGHTFIELD``, ``kernels.VOXELS``).
HEIGHTFIELD_KIND, VOXELS_KIND = 0, 1


@dataclass(frozen=True)
class TracingSnapshot:
    """What the tracer reads, frozen for a batch: the ground height (m, nodata filled; on voxel
    terrains their top surface, where particles are emitted), the surface material index per
    cell, the materials' K_ε (Pa^-a) and τ_c (Pa), and for ``kind`` ``VOXELS_KIND`` the voxel
    level ``volume`` (float32[rows, columns, layers], > 0 in the ground, layer k's centre at
    z0 + (k + ½)·dz m) and its material index ``volume_material`` (int16, empty: material 0)."""

    surface: np.ndarray
    material: np.ndarray
    k_eps: np.ndarray
    tau_c: np.ndarray
    kind: int = HEIGHTFIELD_KIND
    volume: np.ndarray = field(default_factory=lambda: np.zeros((1, 1, 1), np.float32))
    volume_material: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 0), np.int16))
    z0: float = -math.inf
    dz: float = math.inf

    def ground_arguments(self) -> tuple[int, np.ndarray, np.ndarray, float, float]:
        """(kind, volume, volume material, z0, dz) of ``kernels.trace_batch``."""
        return self.kind, self.volume, self.volume_material, float(self.z0), float(self.dz)


class Terrain(ABC):
    """A terrain particles can hit and alter (003 §4). ``grid`` gives cell sizes and domain."""

    grid: Grid

    @abstractmethod
    def surface(self) -> np.ndarray:
        """Ground elevation float64[ny, nx] (m); values on nodata cells are not meaningful."""

    @abstractmethod
    def tracing_snapshot(self, default: Material) -> TracingSnapshot:
        """The frozen state the tracer reads; ``default``: the material of a terrain without one."""

    @abstractmethod
    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray) -> None:
        """Apply changes Q (m³; > 0 deposits) at points (x, y, z) (m) with radii R (m), in order
        (a heightfield's change does not depend on z)."""

    @abstractmethod
    def copy(self) -> Terrain:
        """An independent copy (``run`` never alters the terrain it is given)."""

    def live_state(self, snapshot: TracingSnapshot) -> tuple:
        """Per-impact application (003 §3): the ``live`` argument of ``kernels.trace_batch``
        with which each impact alters ``snapshot``, the ground the tracer reads, at once (and
        this terrain's own arrays where the tracer does not read them); ``absorb`` then takes
        the snapshot's state back. ValueError for a terrain that cannot."""
        raise ValueError("per-impact application works on heightfields and on density and binary voxels")

    def absorb(self, snapshot: TracingSnapshot, live: tuple) -> None:
        """Take back the state a per-impact batch left in ``snapshot`` and ``live``."""
        raise ValueError("per-impact application works on heightfields and on density and binary voxels")

    def matter(self) -> float:
        """Volume of the ground (m³) above an arbitrary datum: what deposits add to and
        detachment takes from (on a heightfield Σ h·cell area over the domain)."""
        return math.fsum(self.surface()[self.grid.valid]) * self.grid.cell_area

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Intersection test: how deep points float64[n, 3] (x, y, z in m) are below the ground
        (m; > 0 inside the ground)."""
        from unerode_cli.particles import terrain_kernels as tk

        p = np.ascontiguousarray(points, dtype=np.float64)
        h = self.tracing_snapshot(Material("default", 0.0)).surface
        return tk.heights(h, p[:, 0].copy(), p[:, 1].copy(), self.grid.dx, self.grid.dy) - p[:, 2]

    def normal(self, points: np.ndarray) -> np.ndarray:
        """Unit outward normals float64[n, 3] of the ground at points float64[n, 2 or 3] (x, y
        and, for 3D terrains, z in m; on a heightfield at the surface above or below (x, y))."""
        from unerode_cli.particles import terrain_kernels as tk

        p = np.ascontiguousarray(points, dtype=np.float64)
        h = self.tracing_snapshot(Material("default", 0.0)).surface
        return tk.normals(h, p[:, 0].copy(), p[:, 1].copy(), self.grid.dx, self.grid.dy)


def _filled(surface: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """The surface with nodata cells set to the lowest valid elevation (particles over nodata
    are lost; this only keeps heights near the domain's border finite)."""
    if valid.all():
        return surface
    return np.where(valid, surface, surface[valid].min())


def _checked_surface(elevation: np.ndarray, grid: Grid, what: str) -> np.ndarray:
    arr = np.array(elevation, dtype=np.float64)
    if arr.shape != grid.shape:
        raise ValueError(f"the {what} has shape {arr.shape}, the grid has {grid.shape}")
    if not grid.valid.any():
        raise ValueError("the grid has no valid cell")
    if not np.isfinite(arr[grid.valid]).all():
        raise ValueError(f"the {what} has non-finite values inside the domain (not nodata)")
    return arr


class HeightfieldTerrain(Terrain):
    """A heightfield h(x, y) (003 §4.1) of one material; impacts add the scaled half-sphere of
    003 Eq. 9. The elevation given is copied."""

    def __init__(self, elevation: np.ndarray, grid: Grid) -> None:
        self.grid = grid
        self._h = _checked_surface(elevation, grid, "elevation")

    def surface(self) -> np.ndarray:
        return self._h.copy()

    def tracing_snapshot(self, default: Material) -> TracingSnapshot:
        return TracingSnapshot(
            _filled(self._h, self.grid.valid).copy(),
            np.zeros(self.grid.shape, np.int32),
            np.array([default.k_eps]),
            np.array([default.tau_c]),
        )

    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray) -> None:
        import numba

        from unerode_cli.particles import terrain_kernels as tk

        tk.apply_heightfield(self._h, self.grid.valid, self.grid.dx, self.grid.dy, x, y, q, radius,
                             numba.get_num_threads())

    def copy(self) -> HeightfieldTerrain:
        return HeightfieldTerrain(self._h, self.grid)

    def live_state(self, snapshot: TracingSnapshot) -> tuple:
        from unerode_cli.particles import kernels

        return (kernels.LIVE_HEIGHTFIELD, *kernels.live_off()[1:])

    def absorb(self, snapshot: TracingSnapshot, live: tuple) -> None:
        valid = self.grid.valid
        self._h[valid] = snapshot.surface[valid]


class LayeredTerrain(Terrain):
    """Material stacks (003 §4.2): a base elevation and layers of given materials on top of it.

    Args:
        base: float64[ny, nx] elevation of the bottom of the stack (m). Below it the bottom
            layer's material goes on without end (erosion through the stack lowers the base).
        thickness: float64[n_layers, ny, nx] layer thicknesses (m, ≥ 0), bottom layer first.
        layer_material: int[n_layers] index into ``materials`` of each layer.
        materials: the material table (K_ε and τ_c of 003 Eq. 2 per material).
        deposit_material: index of the material deposits become (003 §4.2 "ground material").
        grid: cell sizes and domain.

    Deposits go into a top layer of ``deposit_material`` (added with zero thickness when the
    top layer is of another material); detachment removes matter from the top down. The ground
    surface is base + Σ thickness at all times. The arrays given are copied.
    """

    def __init__(self, base: np.ndarray, thickness: np.ndarray, layer_material: Sequence[int],
                 materials: Sequence[Material], deposit_material: int, grid: Grid) -> None:
        self.grid = grid
        self.materials = tuple(materials)
        self._base = _checked_surface(base, grid, "base elevation")
        th = np.array(thickness, dtype=np.float64)
        mats = np.array(layer_material, dtype=np.int64).reshape(-1)
        if th.ndim != 3 or th.shape[1:] != grid.shape or th.shape[0] < 1:
            raise ValueError(f"thickness must have shape (n_layers, {grid.shape[0]}, {grid.shape[1]}), "
                             f"got {th.shape}")
        if mats.size != th.shape[0]:
            raise ValueError(f"{mats.size} layer materials given for {th.shape[0]} layers")
        n_mat = len(self.materials)
        if not (0 <= deposit_material < n_mat) or mats.min() < 0 or mats.max() >= n_mat:
            raise ValueError(f"material indices must be in [0, {n_mat - 1}]")
        inside = th[:, grid.valid]
        if not (np.isfinite(inside).all() and (inside >= 0).all()):
            raise ValueError("layer thicknesses must be finite and ≥ 0 inside the domain")
        th[:, ~grid.valid] = 0.0
        if mats[-1] != deposit_material:
            th = np.concatenate([th, np.zeros((1, *grid.shape))])
            mats = np.append(mats, deposit_material)
        self._thickness = th
        self._layer_material = mats
        self.deposit_material = int(deposit_material)

    @property
    def thickness(self) -> np.ndarray:
        """Copy of the layer thicknesses float64[n_layers, ny, nx] (m), the deposit layer on top."""
        return self._thickness.copy()

    @property
    def layer_material(self) -> np.ndarray:
        """Material index of each layer, bottom first (the deposit layer last)."""
        return self._layer_material.copy()

    @property
    def base(self) -> np.ndarray:
        """Copy of the base elevation (m)."""
        return self._base.copy()

    def surface(self) -> np.ndarray:
        return self._base + self._thickness.sum(axis=0)

    def surface_material(self) -> np.ndarray:
        """Material index of the ground at each cell (int32[ny, nx])."""
        from unerode_cli.particles import terrain_kernels as tk

        return tk.top_material(self._thickness, self._layer_material)

    def tracing_snapshot(self, default: Material) -> TracingSnapshot:
        return TracingSnapshot(
            _filled(self.surface(), self.grid.valid),
            self.surface_material(),
            np.array([m.k_eps for m in self.materials]),
            np.array([m.tau_c for m in self.materials]),
        )

    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray) -> None:
        from unerode_cli.particles import terrain_kernels as tk

        tk.apply_layered(self._base, self._thickness, self.grid.valid, self._thickness.shape[0] - 1,
                         self.grid.dx, self.grid.dy, x, y, q, radius)

    def copy(self) -> LayeredTerrain:
        new = LayeredTerrain.__new__(LayeredTerrain)
        new.grid = self.grid
        new.materials = self.materials
        new._base = self._base.copy()
        new._thickness = self._thickness.copy()
        new._layer_material = self._layer_material.copy()
        new.deposit_material = self.deposit_material
        return new
