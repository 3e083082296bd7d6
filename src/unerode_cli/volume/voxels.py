"""Voxel grids of 3D terrains (003 §4.4): density voxels f ∈ [−1, 1] and binary voxels with hit
counts, each with an optional material index per voxel, and blocks of them under a heightfield.
The changes a point source of matter makes to them (003 Eq. 13–14) and their top surface are
the numba kernels of ``voxel_kernels``. Nothing here knows about particles, nor loads numba.

Layout: arrays are indexed [row, column, layer]: row 0 is the north row, layer 0 the bottom one,
so a column's layers are contiguous. Voxel (r, c, k) spans x ∈ [x0 + c·dx, x0 + (c + 1)·dx],
y ∈ [y0 − (r + 1)·dy, y0 − r·dy] (map coordinates, y north) and z ∈ [z0 + k·dz, z0 + (k + 1)·dz],
with (x0, y0, z0) = ``VoxelGeometry.origin`` (west face, north face, bottom face; m).
The point kernels below take *grid* coordinates: x = column·dx, y = row·dy (m, y south, voxel
centres at integer column and row) and z in metres (voxel k's centre at z0 + (k + ½)·dz).

Density voxels (003 §4.4): f = 1 is full, f = −1 empty, between partly full; the matter of a
voxel is (1 + f)/2 of its volume, and the ground surface is the f = 0 level. Binary voxels: a
voxel is ground or background (air); hits accumulate until a voxel flips.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Material index arrays hold this many materials at most (int16).
MAX_MATERIALS = 32767


@dataclass(frozen=True)
class VoxelGeometry:
    """Where a voxel grid lies: ``origin`` (x of the west face, y of the north face, z of the
    bottom face; m, map coordinates), ``size`` (dx east-west, dy north-south, dz vertical; m)
    and ``shape`` (rows, columns, layers)."""

    origin: tuple[float, float, float]
    size: tuple[float, float, float]
    shape: tuple[int, int, int]

    def __post_init__(self) -> None:
        if len(self.shape) != 3 or min(self.shape) < 1:
            raise ValueError(f"a voxel grid needs at least one voxel along each axis, got shape {self.shape}")
        if not all(math.isfinite(s) and s > 0 for s in self.size):
            raise ValueError(f"voxel sizes must be finite and > 0 m, got {self.size}")
        if not all(math.isfinite(o) for o in self.origin):
            raise ValueError(f"the voxel grid's origin must be finite, got {self.origin}")

    @property
    def voxel_volume(self) -> float:
        """Volume of one voxel (m³)."""
        return self.size[0] * self.size[1] * self.size[2]

    @property
    def count(self) -> int:
        """Number of voxels."""
        return self.shape[0] * self.shape[1] * self.shape[2]

    def layer_centres(self) -> np.ndarray:
        """Elevation (m) of the centre of each layer, bottom first: float64[layers]."""
        return self.origin[2] + (np.arange(self.shape[2]) + 0.5) * self.size[2]


def _checked_material(material: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray | None:
    if material is None:
        return None
    mat = np.asarray(material)
    if mat.shape != shape or not np.issubdtype(mat.dtype, np.integer):
        raise ValueError(f"the material index must be integers of shape {shape}, got {mat.dtype} {mat.shape}")
    if mat.size and (mat.min() < 0 or mat.max() > MAX_MATERIALS):
        raise ValueError(f"material indices must be in [0, {MAX_MATERIALS}]")
    return np.array(mat, dtype=np.int16, order="C")


def _checked_valid(valid: np.ndarray | None, shape: tuple[int, int, int]) -> np.ndarray:
    if valid is None:
        return np.ones(shape[:2], dtype=bool)
    arr = np.asarray(valid)
    if arr.shape != shape[:2] or arr.dtype != np.bool_:
        raise ValueError(f"the column mask must be booleans of shape {shape[:2]}, "
                         f"got {arr.dtype} {arr.shape}")
    return arr.copy()


@dataclass
class DensityVoxels:
    """Density voxels (003 §4.4): ``density`` float64[rows, columns, layers] in [−1, 1], an
    optional ``material`` int16 index per voxel, and ``valid`` bool[rows, columns], the columns
    inside the domain. The arrays given are copied."""

    geometry: VoxelGeometry
    density: np.ndarray
    material: np.ndarray | None = None
    valid: np.ndarray | None = None

    def __post_init__(self) -> None:
        f = np.array(self.density, dtype=np.float64, order="C")
        if f.shape != self.geometry.shape:
            raise ValueError(f"the density has shape {f.shape}, the grid {self.geometry.shape}")
        if not (np.isfinite(f).all() and f.min() >= -1.0 and f.max() <= 1.0):
            raise ValueError("densities must be finite and within [-1, 1]")
        self.density = f
        self.material = _checked_material(self.material, f.shape)
        self.valid = _checked_valid(self.valid, self.geometry.shape)

    def matter(self) -> float:
        """Volume of matter (m³): Σ (1 + f)/2 over the voxels of valid columns, times a voxel's."""
        f = self.density[self.valid]
        return math.fsum(((1.0 + f) * 0.5).ravel()) * self.geometry.voxel_volume

    def copy(self) -> DensityVoxels:
        return DensityVoxels(self.geometry, self.density, self.material, self.valid)


@dataclass
class BinaryVoxels:
    """Binary voxels (003 §4.4): ``solid`` bool[rows, columns, layers] (ground or air), ``hits``
    int32 of the same shape (> 0: erosion received, < 0: deposition), an optional ``material``
    int16 index and ``valid`` bool[rows, columns]. The arrays given are copied."""

    geometry: VoxelGeometry
    solid: np.ndarray
    hits: np.ndarray | None = None
    material: np.ndarray | None = None
    valid: np.ndarray | None = None

    def __post_init__(self) -> None:
        s = np.array(self.solid, order="C")
        if s.shape != self.geometry.shape or s.dtype != np.bool_:
            raise ValueError(f"the solid mask must be booleans of shape {self.geometry.shape}, "
                             f"got {s.dtype} {s.shape}")
        hits = np.zeros(s.shape, np.int32) if self.hits is None else np.asarray(self.hits)
        if hits.shape != s.shape or not np.issubdtype(hits.dtype, np.integer):
            raise ValueError(f"hit counts must be integers of shape {s.shape}, got {hits.dtype} {hits.shape}")
        self.solid = s
        self.hits = np.array(hits, dtype=np.int32, order="C")
        self.material = _checked_material(self.material, s.shape)
        self.valid = _checked_valid(self.valid, self.geometry.shape)

    def matter(self) -> float:
        """Volume of ground (m³): solid voxels of valid columns times a voxel's volume."""
        return float(np.count_nonzero(self.solid[self.valid])) * self.geometry.voxel_volume

    def copy(self) -> BinaryVoxels:
        return BinaryVoxels(self.geometry, self.solid, self.hits, self.material, self.valid)


def block_geometry(west: float, north: float, width: float, height: float, bottom: float, top: float,
                   voxel_size: float) -> VoxelGeometry:
    """A grid over the rectangle [west, west + width] × [north − height, north] (m, map
    coordinates) and the elevations [bottom, top] (m): whole columns of about ``voxel_size``
    (their sizes adjusted to fill the rectangle exactly) and layers of ``voxel_size`` from
    ``bottom`` up to ``top`` or just above."""
    if not (math.isfinite(voxel_size) and voxel_size > 0):
        raise ValueError(f"the voxel size must be > 0 m, got {voxel_size}")
    cols = max(1, round(width / voxel_size))
    rows = max(1, round(height / voxel_size))
    layers = max(1, math.ceil((top - bottom) / voxel_size - 1e-9))
    size = (width / cols, height / rows, voxel_size)
    return VoxelGeometry((west, north, bottom), size, (rows, cols, layers))


def column_heights(elevation: np.ndarray, valid: np.ndarray, dx: float, dy: float,
                   shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """A heightfield (m, cells dx × dy m, ``valid`` its domain) sampled at the centres of
    ``shape`` = (rows, columns) columns covering the same extent: bilinear heights and the
    validity of the nearest cell. Returns (float64[rows, columns], bool[rows, columns])."""
    from scipy.ndimage import map_coordinates

    ny, nx = elevation.shape
    rows, cols = shape
    r = (np.arange(rows) + 0.5) * (ny / rows) - 0.5
    c = (np.arange(cols) + 0.5) * (nx / cols) - 0.5
    rr, cc = np.meshgrid(np.clip(r, 0, ny - 1), np.clip(c, 0, nx - 1), indexing="ij")
    filled = np.where(valid, elevation, elevation[valid].min() if valid.any() else 0.0)
    heights = map_coordinates(filled, [rr, cc], order=1, mode="nearest")
    near = valid[np.rint(rr).astype(int), np.rint(cc).astype(int)]
    return heights, near


def density_block(heights: np.ndarray, geometry: VoxelGeometry) -> np.ndarray:
    """Density voxels of the ground below ``heights`` (m, one per column): f = (h − z)/dz at each
    voxel centre z, clipped to [−1, 1]. The f = 0 level of the trilinear density is then the
    surface h exactly, and Σ (1 + f)/2·dz over a column equals h − z0 (the matter under the
    surface): a ramp of width 2dz sampled at spacing dz sums to its integral."""
    z = geometry.layer_centres()
    return np.clip((heights[:, :, None] - z[None, None, :]) / geometry.size[2], -1.0, 1.0)


def binary_block(heights: np.ndarray, geometry: VoxelGeometry) -> np.ndarray:
    """Binary voxels of the ground below ``heights`` (m): a voxel is ground when its centre is."""
    return geometry.layer_centres()[None, None, :] < heights[:, :, None]


def horizon_material(geometry: VoxelGeometry, tops: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Material index of each voxel for horizontal horizons: horizon i (bottom first) spans the
    elevations up to ``tops[i]`` (m, increasing; the last may be inf) and is made of material
    ``indices[i]``; a voxel takes the horizon of its centre, the top horizon above every top.
    Returns int16[rows, columns, layers]."""
    tops = np.asarray(tops, dtype=np.float64)
    which = np.minimum(np.searchsorted(tops, geometry.layer_centres(), side="right"), len(tops) - 1)
    per_layer = np.asarray(indices, dtype=np.int16)[which]
    return np.ascontiguousarray(np.broadcast_to(per_layer, geometry.shape))


def xyz_to_grid(array: np.ndarray) -> np.ndarray:
    """Axes (x east, y north[, z up]) → this module's [row (north first), column[, layer]]."""
    return np.ascontiguousarray(np.swapaxes(array, 0, 1)[::-1])


def grid_to_xyz(array: np.ndarray) -> np.ndarray:
    """This module's [row, column[, layer]] → axes (x east, y north[, z up])."""
    return np.ascontiguousarray(np.swapaxes(array[::-1], 0, 1))


def ground_mesh(voxels: DensityVoxels | BinaryVoxels):
    """The closed surface mesh (``volume.mesh.Mesh``) of the ground of a voxel grid: the f = 0
    level of the density (binary voxels as ±1) through the voxel centres, the grid padded with
    empty voxels so that the mesh closes; vertices in m from the grid's south-west bottom
    corner, coloured by the material of the nearest voxel (0 without materials). Needs
    scikit-image (``volume.mesh.MeshExtraMissing`` otherwise)."""
    from unerode_cli.volume.mesh import Mesh, surface_mesh

    if isinstance(voxels, DensityVoxels):
        level = np.where(voxels.valid[:, :, None], voxels.density, -1.0)
    else:
        level = np.where(voxels.solid & voxels.valid[:, :, None], 1.0, -1.0)
    padded = np.pad(grid_to_xyz(level), 1, constant_values=-1.0)
    material = None
    if voxels.material is not None:
        material = np.pad(grid_to_xyz(voxels.material), 1, mode="edge")
    mesh = surface_mesh(padded, (0.0, 0.0, 0.0), 1.0, level=0.0, materials=material)
    vertices = (mesh.vertices - 0.5) * np.asarray(voxels.geometry.size)
    return Mesh(vertices, mesh.faces, mesh.materials, mesh.colours)

