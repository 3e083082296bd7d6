"""3D volumes built from a heightfield (003 §4.4): the voxel block under a DEM and the
conversion of voxels between their two kinds.

A block spans the DEM's extent (whole columns of about the voxel size, their sizes adjusted to
fill it) and its elevations, from ``depth`` below its lowest cell (or the bottom of an extra
``extent``) to ``headroom`` above its highest one, and is filled up to the DEM's surface as
density voxels (``density_block``) or binary voxels (``binary_block``). Arrays and numbers in:
elevations float64[ny, nx] (m, NaN or ``valid`` False outside the domain), cell sizes dx, dy (m),
map coordinates of the DEM's west and north edges (m). Nothing here reads a file.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.volume.voxels import (
    BinaryVoxels,
    DensityVoxels,
    VoxelGeometry,
    binary_block,
    block_geometry,
    column_heights,
    density_block,
)

#: A block reaches this many voxels below the DEM's lowest cell and above its highest one
#: unless a depth / headroom (m) is given.
DEFAULT_DEPTH_VOXELS = 10
DEFAULT_HEADROOM_VOXELS = 10
#: The kinds of voxels a block can be made of.
VOXEL_KINDS = ("density", "binary")


@dataclass(frozen=True)
class BlockFrame:
    """The voxels of a block under a DEM, the DEM's heights at their columns
    (float64[rows, columns], m, bilinear) and the columns inside its domain (bool[rows, columns])."""

    geometry: VoxelGeometry
    heights: np.ndarray
    columns: np.ndarray


def geometry_under(elevation: np.ndarray, dx: float, dy: float, west: float, north: float,
                   voxel_size: float | None = None, depth: float | None = None,
                   headroom: float | None = None,
                   extent: tuple[float, float] | None = None) -> VoxelGeometry:
    """The voxels of the block under a DEM (elevations float[ny, nx], m, NaN outside its domain;
    cells dx × dy m, north-west corner at (``west``, ``north``)): voxels of ``voxel_size`` m
    (default: the mean cell size) from ``depth`` m below the lowest cell to ``headroom`` m above
    the highest (default ``DEFAULT_DEPTH_VOXELS`` / ``DEFAULT_HEADROOM_VOXELS`` voxels), the
    elevations ``extent`` = (low, high) m included. ValueError (one sentence) when a size is
    not positive."""
    size = voxel_size or 0.5 * (dx + dy)
    low, high = float(np.nanmin(elevation)), float(np.nanmax(elevation))
    if extent is not None:
        low, high = min(low, extent[0]), max(high, extent[1])
    below = DEFAULT_DEPTH_VOXELS * size if depth is None else depth
    above = DEFAULT_HEADROOM_VOXELS * size if headroom is None else headroom
    ny, nx = elevation.shape
    return block_geometry(west, north, nx * dx, ny * dy, low - below, high + above, size)


def frame(geometry: VoxelGeometry, elevation: np.ndarray, valid: np.ndarray, dx: float,
          dy: float) -> BlockFrame:
    """The DEM's heights (m) and domain sampled at the columns of ``geometry``, which covers the
    DEM's extent (``geometry_under``)."""
    heights, columns = column_heights(elevation, valid, dx, dy, geometry.shape[:2])
    return BlockFrame(geometry, heights, columns)


def filled_block(block: BlockFrame, kind: str) -> DensityVoxels | BinaryVoxels:
    """The ground of ``block`` up to the DEM's surface as ``kind`` voxels (``VOXEL_KINDS``):
    density voxels f = (h − z)/dz clipped to [−1, 1] (003 Eq. 13's f = 0 level at the surface),
    or binary voxels solid where their centre is below it (003 Eq. 14)."""
    geometry, heights = block.geometry, block.heights
    if kind == "density":
        return DensityVoxels(geometry, density_block(heights, geometry), valid=block.columns)
    if kind == "binary":
        return BinaryVoxels(geometry, binary_block(heights, geometry), valid=block.columns)
    raise ValueError(f"voxels are density or binary, not {kind!r}")


def as_kind(voxels: DensityVoxels | BinaryVoxels, kind: str) -> DensityVoxels | BinaryVoxels:
    """``voxels`` as ``kind`` voxels (003 §4.4: one can be turned into the other): binary voxels
    read as densities ±1, densities as binary voxels solid where f > 0; material index and
    domain kept. Voxels of that kind already are returned as they are."""
    if kind == "density" and isinstance(voxels, BinaryVoxels):
        density = np.where(voxels.solid, 1.0, -1.0)
        return DensityVoxels(voxels.geometry, density, voxels.material, voxels.valid)
    if kind == "binary" and isinstance(voxels, DensityVoxels):
        return BinaryVoxels(voxels.geometry, voxels.density > 0.0, None, voxels.material, voxels.valid)
    return voxels
