"""Implicit terrains particles alter (003 §4.3): a signed distance function — the surface of a DEM
or a scene of primitives — altered by a metaball at every impact (003 Eq. 11), held by
``volume.sdf_field.ImplicitField``.

The tracer reads the field's node cache as a voxel level (a ``TracingSnapshot`` of kind
VOXELS: −f/dz, > 0 in the ground, trilinear between the nodes), so it finds where a particle
meets the f = 0 surface and takes the normal from the gradient of f (003 §4's two conditions,
Eq. 12) with the ground queries of ``voxel_kernels``: one tracer for every representation.
Impacts are applied in particle order as metaballs put on the surface as the impacts before
them left it (``volume.sdf_kernels.place_changes``); a particle that dies in flight leaves its
load on the ground straight below it.

Coordinates are the tracer's: x = column·dx, y = row·dy (m, y south) over the field's columns,
z the elevation (m). ``volume.sdf_field`` (and numba) load when a terrain is built.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.particles.terrain import VOXELS_KIND, Material, Terrain, TracingSnapshot, _filled

if TYPE_CHECKING:
    from unerode_cli.volume.sdf_field import ImplicitField
    from unerode_cli.volume.voxels import DensityVoxels, VoxelGeometry

#: Bytes a run needs per node of the cache: the field given and the field altered (8 + 8), the
#: flattened base of the altered one (8) and the tracer's float32 level (4).
RUN_BYTES_PER_NODE = 28


def sdf_run_bytes(nodes: int) -> int:
    """Bytes a particle run on an implicit terrain of ``nodes`` cache nodes needs."""
    return nodes * RUN_BYTES_PER_NODE


class SdfTerrain(Terrain):
    """An implicit terrain (003 §4.3) of one material (the run's K_ε and τ_c).

    Args:
        field: the signed distance function and its cache (copied).
        valid: bool[rows, columns], the columns inside the domain (default: all).
    """

    def __init__(self, field: ImplicitField, valid: np.ndarray | None = None) -> None:
        self.field = field.copy()
        dx, dy, _ = field.geometry.size
        shape = field.geometry.shape[:2]
        mask = np.ones(shape, bool) if valid is None else np.asarray(valid, dtype=bool)
        if mask.shape != shape:
            raise ValueError(f"the column mask has shape {mask.shape}, the field's columns {shape}")
        self.grid = Grid(dx, dy, mask.copy())
        if not self.grid.valid.any():
            raise ValueError("the implicit terrain has no valid column")

    @property
    def geometry(self) -> VoxelGeometry:
        """The nodes of the field's cache (``volume.voxels`` layout)."""
        return self.field.geometry

    def surface(self) -> np.ndarray:
        """The highest zero crossing of f in each column (m)."""
        return self.field.top_surface()

    def tracing_snapshot(self, default: Material) -> TracingSnapshot:
        _, _, dz = self.geometry.size
        return TracingSnapshot(
            _filled(self.surface(), self.grid.valid),
            np.zeros((1, 1), np.int32),
            np.array([default.k_eps]),
            np.array([default.tau_c]),
            kind=VOXELS_KIND, volume=self.field.level(), z0=self.geometry.origin[2], dz=dz,
        )

    def apply(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, q: np.ndarray, radius: np.ndarray) -> None:
        self.field.apply(x, y, z, q, radius, self.grid.valid)

    def copy(self) -> SdfTerrain:
        return SdfTerrain(self.field, self.grid.valid)

    def matter(self) -> float:
        """Volume of the ground (m³) in the valid columns of the cache (f linear between nodes)."""
        return self.field.inside_volume(self.grid.valid)

    def depth(self, points: np.ndarray) -> np.ndarray:
        """−f (m) of the exact field at points float64[n, 3] (m): > 0 in the ground."""
        return -self.field.evaluate(points)

    def normal(self, points: np.ndarray) -> np.ndarray:
        """Unit outward normals ∇f/‖∇f‖ float64[n, 3] of the exact field at points float64[n, 3]."""
        p = np.asarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError("normals of an implicit terrain need points (x, y, z)")
        return self.field.normals(p)

    def density_voxels(self) -> DensityVoxels:
        """The terrain as density voxels on the cache's nodes (``ImplicitField.density_voxels``)."""
        return self.field.density_voxels(self.grid.valid)
