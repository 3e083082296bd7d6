"""Particles as a smooth density on a regular grid: the volume field a surface mesh is drawn from.

Each particle stands for ``particle_volume`` m³ of rock (a sampling lattice of spacing s gives
s³). Its volume is spread over the 8 nearest grid nodes by cloud-in-cell (trilinear) weights and
the result blurred by a Gaussian of ``sigma`` nodes along each axis (a separable kernel), so the
density is the local volume fraction of rock: ≈ 1 inside, 0 far outside, and ½ on the boundary of
a flat face, which is where the level-½ surface (:func:`~unerode_cli.volume.mesh.surface_mesh`)
goes. Convex shapes lose a thin rim of order σ²/R (R the radius of curvature): for R = 20 nodes and
σ = 1 node, about 2 % of a ball's volume. 002 (§3, Alg. 1) meshes its particles by screened
Poisson reconstruction instead; a density and marching cubes need no normals and give a closed
surface whatever the particles.

The grid extends ``pad`` nodes beyond the particles on every side, where the density is zero, so
every surface is closed. With a ``ground`` altitude (m), the rock stands on the ground plane: the
particles near it are mirrored below it before the blur (so the density does not fade towards
the ground), the nodes below the ground are emptied, and a node layer lies on the ground; the
mesh then closes along the ground plane (see :func:`~unerode_cli.volume.mesh.surface_mesh`).

Node (i, j, k) of a grid lies at ``origin + h·(i, j, k)`` (m); arrays have shape (nx, ny, nz).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter

#: Standard deviation of the blur, in grid nodes, and where it is cut (in standard deviations).
SIGMA = 1.0
TRUNCATE = 3.0
#: Empty nodes kept beyond the reach of the blur on every side.
MARGIN = 2
#: Material index of a node without rock.
NO_MATERIAL = -1


@dataclass(frozen=True)
class Density:
    """A rock volume fraction ``values`` (float32, dimensionless) at the nodes
    ``origin + h·(i, j, k)`` (m), the dominant ``materials`` (int16, :data:`NO_MATERIAL` where
    there is no rock) and the ``ground`` altitude (m) the rock stands on, or None."""

    values: np.ndarray
    materials: np.ndarray
    origin: tuple[float, float, float]
    h: float
    ground: float | None = None


def particle_density(positions: np.ndarray, materials: np.ndarray, particle_volume: float, h: float,
                     sigma: float = SIGMA, ground: float | None = None) -> Density:
    """The density of particles at ``positions`` (N, 3) (m), each ``particle_volume`` m³ of the
    material ``materials`` (N,) (integers ≥ 0, e.g. layer indices), on a grid of node spacing
    ``h`` (m) blurred by ``sigma`` nodes; ``ground``: the altitude (m) of the plane the rock
    stands on (see the module's text). The dominant material of a node is the one of largest
    blurred density there."""
    positions = np.asarray(positions, dtype=np.float64)
    materials = np.asarray(materials)
    if not (h > 0.0 and particle_volume > 0.0 and sigma > 0.0):
        raise ValueError("the node spacing, particle volume and blur must be positive")
    reach = math.ceil(TRUNCATE * sigma) + MARGIN
    if ground is not None:
        positions, materials = _mirrored(positions, materials, ground, reach * h)
    if len(positions) == 0:
        raise ValueError("there are no particles (above the ground) to make a density of")
    if materials.min() < 0:
        raise ValueError("material indices must be non-negative")
    origin = positions.min(axis=0) - reach * h
    if ground is not None:  # a node layer on the ground, at least one below it
        origin[2] = ground - h * math.ceil((ground - min(origin[2], ground - h)) / h)
    shape = tuple(int(n) for n in np.floor((positions.max(axis=0) + reach * h - origin) / h) + 2)
    scale = particle_volume / h**3
    total = np.zeros(shape, dtype=np.float32)
    best = np.zeros(shape, dtype=np.float32)
    dominant = np.full(shape, NO_MATERIAL, dtype=np.int16)
    for material in np.unique(materials):
        mine = positions[materials == material]
        field = gaussian_filter(_cloud_in_cell(mine, origin, h, shape, scale), sigma, mode="constant",
                                truncate=TRUNCATE)
        total += field
        larger = field > best
        best[larger] = field[larger]
        dominant[larger] = material
    if ground is None:
        return Density(total, dominant, tuple(map(float, origin)), h)  # type: ignore[arg-type]
    below = int(round((ground - origin[2]) / h))  # the node layer on the ground
    total = total[:, :, below - 1:]
    total[:, :, 0] = 0.0
    origin[2] = ground - h
    return Density(total, dominant[:, :, below - 1:], tuple(map(float, origin)), h,  # type: ignore[arg-type]
                   float(ground))


def _mirrored(positions: np.ndarray, materials: np.ndarray, ground: float,
              reach: float) -> tuple[np.ndarray, np.ndarray]:
    """The particles and, appended, the mirror images below ``ground`` of those within
    ``reach`` (m) above it; particles below the ground are dropped."""
    above = positions[:, 2] >= ground
    positions, materials = positions[above], materials[above]
    near = positions[:, 2] < ground + reach
    images = positions[near].copy()
    images[:, 2] = 2.0 * ground - images[:, 2]
    return np.concatenate([positions, images]), np.concatenate([materials, materials[near]])


def _cloud_in_cell(positions: np.ndarray, origin: np.ndarray, h: float, shape: tuple[int, ...],
                   scale: float) -> np.ndarray:
    """``scale`` per particle spread over its 8 nearest nodes with trilinear weights (float32)."""
    f = (positions - origin) / h
    base = np.floor(f).astype(np.int64)
    t = f - base
    strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)
    size = int(np.prod(shape))
    grid = np.zeros(size, dtype=np.float64)
    for corner in np.ndindex(2, 2, 2):
        offset = np.asarray(corner)
        weight = scale * np.prod(np.where(offset == 1, t, 1.0 - t), axis=1)
        grid += np.bincount((base + offset) @ strides, weights=weight, minlength=size)
    return grid.reshape(shape).astype(np.float32)
