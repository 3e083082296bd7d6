"""Sampling a solid with particles on a jittered lattice (002 §3.3 "sample the particles
uniformly within the initial shape").

The lattice has spacing ``s`` (m); each lattice cell holds at most one particle, jittered by up to
a quarter spacing from the cell's centre, so the *surface grid* (cells of edge s, 002 §5.1: "a
resolution close to their spacing") holds one particle per filled cell and the *MPM grid* (cells
of edge 2s) about eight, the usual MLS-MPM density. A solid is anything with
``contains(points (M, 3)) -> bool (M,)``: a scene's CSG tree or an extruded DEM.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.layers import LayerStack
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.scene import Scene, lattice_value, value_noise

#: Jitter of a particle from its lattice cell's centre, in spacings along each axis.
JITTER = 0.25
#: MPM cells are this many lattice spacings wide (8 particles per cell).
MPM_CELL_SPACINGS = 2
#: Bytes a particle needs during a run: its state (position, velocity, affine velocity and
#: deformation gradient in float64, normals, layer, viability, erodibility, vegetation, flags)
#: and the per-frame work arrays (rates, surface flags, the neighbour tree of the normals).
BYTES_PER_PARTICLE = 800
#: Bytes per MPM grid node (mass, momentum, float64) and per surface-grid cell (occupancy and
#: the wind and deposition work arrays).
BYTES_PER_NODE = 48
BYTES_PER_SURFACE_CELL = 24
#: Points of the regular probe that estimates a solid's volume before sampling.
VOLUME_PROBE_POINTS = 1 << 21
#: Lattice points evaluated at once while sampling (bounds the sampler's memory).
CHUNK_POINTS = 1 << 22


class Solid(Protocol):
    def contains(self, points: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Lattice:
    """The sampling lattice over the domain ``low`` + [0, ``size``] (m), spacing ``spacing`` (m)."""

    low: tuple[float, float, float]
    size: tuple[float, float, float]
    spacing: float

    @property
    def shape(self) -> tuple[int, int, int]:
        """Lattice cells along x, y, z (rounded up to a whole number of MPM cells)."""
        n = np.ceil(np.asarray(self.size) / (self.spacing * MPM_CELL_SPACINGS) - 1e-9).astype(int)
        return tuple(int(v) * MPM_CELL_SPACINGS for v in np.maximum(n, 1))  # type: ignore[return-value]

    @property
    def points(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64))

    def surface_grid(self) -> Grid3D:
        """The grid of surfaces, normals and wind shelter: one lattice cell per cell."""
        return Grid3D(self.low, self.spacing, self.shape)

    def mpm_grid(self) -> Grid3D:
        """The MLS-MPM grid, also that of deposition: cells of ``MPM_CELL_SPACINGS`` lattice spacings."""
        shape = tuple(n // MPM_CELL_SPACINGS for n in self.shape)
        return Grid3D(self.low, self.spacing * MPM_CELL_SPACINGS, shape)  # type: ignore[arg-type]


def solid_fraction(solid: Solid, low: np.ndarray, size: np.ndarray,
                   probe_points: int = VOLUME_PROBE_POINTS) -> float:
    """The share of the domain's volume the solid fills, from a regular probe of about
    ``probe_points`` points (cell centres of a grid with cubic-ish cells)."""
    step = (float(np.prod(size)) / probe_points) ** (1.0 / 3.0)
    counts = np.maximum(1, np.round(np.asarray(size) / step)).astype(int)
    axes = [low[a] + (np.arange(counts[a]) + 0.5) * size[a] / counts[a] for a in range(3)]
    inside = 0
    for z in axes[2]:
        xx, yy = np.meshgrid(axes[0], axes[1], indexing="ij")
        points = np.column_stack([xx.ravel(), yy.ravel(), np.full(xx.size, z)])
        inside += int(solid.contains(points).sum())
    return inside / float(np.prod(counts))


def spacing_for(volume: float, particles: int) -> float:
    """Lattice spacing (m) that puts about ``particles`` particles in ``volume`` (m³)."""
    return (volume / particles) ** (1.0 / 3.0)


def memory_estimate(particles: float, lattice: Lattice) -> float:
    """Bytes a run of ``particles`` particles on ``lattice`` needs (see the constants)."""
    mpm = lattice.mpm_grid().shape
    nodes = math.prod(n + 3 for n in mpm)
    return particles * BYTES_PER_PARTICLE + nodes * BYTES_PER_NODE + lattice.points * BYTES_PER_SURFACE_CELL


def sample(solid: Solid, lattice: Lattice, seed: int) -> np.ndarray:
    """Positions ``(N, 3)`` (m) of the jittered lattice points inside ``solid``: one per lattice
    cell whose jittered point the solid contains. The jitter of a cell depends only on ``seed``
    and the cell's index, so the result does not depend on how the lattice is chunked."""
    nx, ny, nz = lattice.shape
    per_slab = nx * ny
    slabs = max(1, CHUNK_POINTS // per_slab)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    found, keys = [], []
    for k0 in range(0, nz, slabs):
        k = np.arange(k0, min(nz, k0 + slabs))
        cells = np.column_stack([np.tile(i.ravel(), len(k)), np.tile(j.ravel(), len(k)),
                                 np.repeat(k, per_slab)]).astype(np.int64)
        jitter = np.column_stack([lattice_value(cells, 3 * seed + a) for a in range(3)]) * JITTER
        points = np.asarray(lattice.low) + (cells + 0.5 + jitter) * lattice.spacing
        inside = solid.contains(points)
        found.append(points[inside])
        keys.append(cells[inside] @ np.array([ny * nz, nz, 1], dtype=np.int64))
    if not found:
        return np.zeros((0, 3))
    return np.concatenate(found)[np.argsort(np.concatenate(keys), kind="stable")]


#: Particles of a scene or extruded DEM that gives no count (nor, for a scene, a cell size).
DEFAULT_PARTICLES = 200_000


@dataclass(frozen=True)
class ExtrudedDem:
    """A DEM extruded into rock: each column of a cell is filled from ``base`` (m) up to the
    cell's elevation. ``elevation`` (ny, nx) has row 0 at the north, NaN for nodata (no rock);
    ``low`` is the south-west corner (m) and ``dx``, ``dy`` the cell sizes (m)."""

    elevation: np.ndarray
    low: tuple[float, float]
    dx: float
    dy: float
    base: float

    def contains(self, points: np.ndarray) -> np.ndarray:
        ny, nx = self.elevation.shape
        col = np.floor((points[:, 0] - self.low[0]) / self.dx).astype(np.int64)
        row = ny - 1 - np.floor((points[:, 1] - self.low[1]) / self.dy).astype(np.int64)
        inside = (col >= 0) & (col < nx) & (row >= 0) & (row < ny)
        top = np.full(len(points), -np.inf)
        top[inside] = self.elevation[row[inside], col[inside]]
        return inside & (points[:, 2] >= self.base) & (points[:, 2] <= np.nan_to_num(top, nan=-np.inf))


def lattice_for(solid: Solid, low: np.ndarray, size: np.ndarray, particles: int | None,
                cell_size: float | None = None) -> tuple[Lattice, float]:
    """The lattice that puts about ``particles`` particles (or, without a count, the spacing of
    MPM cells of ``cell_size`` m, or else :data:`DEFAULT_PARTICLES`) in the solid, and the
    particle count it is expected to give — before any sampling."""
    volume = solid_fraction(solid, low, size) * float(np.prod(size))
    if volume <= 0.0:
        raise ValueError("the rock does not fill any part of the domain")
    if particles is None and cell_size is not None:
        spacing = cell_size / MPM_CELL_SPACINGS
    else:
        spacing = spacing_for(volume, particles or DEFAULT_PARTICLES)
    lattice = Lattice(tuple(map(float, low)), tuple(map(float, size)), spacing)  # type: ignore[arg-type]
    return lattice, volume / spacing**3


def top_surface(positions: np.ndarray, low: tuple[float, float], dx: float, dy: float,
                shape: tuple[int, int], ground: float, spacing: float) -> np.ndarray:
    """The top heightfield (m), ``shape`` (ny, nx) with row 0 at the north: in each cell's
    column, the highest particle plus half a spacing, or the ``ground`` where there is none."""
    ny, nx = shape
    col = np.floor((positions[:, 0] - low[0]) / dx).astype(np.int64)
    row = ny - 1 - np.floor((positions[:, 1] - low[1]) / dy).astype(np.int64)
    inside = (col >= 0) & (col < nx) & (row >= 0) & (row < ny)
    top = np.full(shape, -np.inf)
    np.maximum.at(top, (row[inside], col[inside]), positions[inside, 2] + 0.5 * spacing)
    return np.where(np.isfinite(top), top, ground)


def scene_particles(scene: Scene, lattice: Lattice, seed: int) -> Particles:
    """The scene's rock as particles: sampled (``sample``), each in the layer of its altitude,
    its erodibility factor exp(amplitude·noise) (002 §3.3) and then the painted regions'
    values, in order, where they paint (later regions override earlier ones)."""
    positions = sample(scene.shape, lattice, seed)
    factor = np.ones(len(positions))
    vegetation = np.zeros(len(positions))
    if scene.noise is not None:
        noise = scene.noise
        values = value_noise(positions, noise.wavelength, noise.seed, noise.octaves)
        factor *= np.exp(noise.amplitude * values)
    for paint in scene.paint:
        inside = paint.shape.contains(positions)
        if paint.erodibility is not None:
            factor[inside] = paint.erodibility
        if paint.vegetation is not None:
            vegetation[inside] = paint.vegetation
    return Particles.new(positions, scene.layer_stack().index_of(positions[:, 2]), factor, vegetation)


def solid_particles(solid: Solid, lattice: Lattice, layers: LayerStack, seed: int) -> Particles:
    """A solid without paint or noise (an extruded DEM) as particles, layered by altitude."""
    positions = sample(solid, lattice, seed)
    return Particles.new(positions, layers.index_of(positions[:, 2]))
