"""Cases of the sandstone's surface and transport stages at about a million particles, for
``bench_sandstone.py`` to register (``harness.benchmark``): surface particles, normals (all,
and near a frame's changes), wind abrasion, deflation, deposition and the block-fall test
(``support_case``); and the water's stages with deposition (``fluvial_case``) on a rock it is
given.

The rock: a block of 128 × 96 × 80 lattice spacings (1 m) pierced by a tunnel of radius 24 m
along y (an arch), on a jittered lattice (a quarter spacing, as the sampler's), about 0.9 M
particles; the surface grid has one lattice cell per cell (160 × 128 × 96), the MPM grid two.
A frame's changes are 2000 surface particles eroded from the tunnel's roof.
"""

from __future__ import annotations

from functools import cache

import numba
import numpy as np

from unerode_cli.sandstone import (
    basins,
    deflation,
    deposition,
    discharge,
    fluvial,
    support,
    surface,
    water_receivers,
    wind,
)
from unerode_cli.sandstone.grid3d import Grid3D

BLOCK = (128, 96, 80)
TUNNEL_RADIUS = 24.0
SURFACE_GRID = Grid3D((-16.0, -16.0, 0.0), 1.0, (160, 128, 96))
MPM_GRID = Grid3D((-16.0, -16.0, 0.0), 2.0, (80, 64, 48))
CHANGES = 2000
SEED = 1


@cache
def _rock() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, surface flags and normals of the bench rock (computed once)."""
    axes = [np.arange(n) + 0.5 for n in BLOCK]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    points += (np.random.default_rng(SEED).random(points.shape) - 0.5) * 0.5
    tunnel = np.hypot(points[:, 0] - BLOCK[0] / 2, points[:, 2]) < TUNNEL_RADIUS
    positions = np.ascontiguousarray(points[~tunnel])
    on_surface = surface.surface_particles(positions, SURFACE_GRID)
    return positions, on_surface, surface.normals(positions, on_surface, SURFACE_GRID)


def _eroded() -> np.ndarray:
    """Indices of the frame's eroded particles: the surface particles nearest the roof's crown."""
    positions, on_surface, _ = _rock()
    index = np.flatnonzero(on_surface)
    crown = np.array([BLOCK[0] / 2, BLOCK[1] / 2, TUNNEL_RADIUS])
    return index[np.argsort(np.linalg.norm(positions[index] - crown, axis=1))[:CHANGES]]


def _threads(threads: int) -> None:
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def surface_case(threads: int = 2):
    positions, _, _ = _rock()

    def work():
        _threads(threads)
        return surface.surface_particles(positions, SURFACE_GRID)

    return work, len(positions), "particles"


def normals_case(threads: int = 2, incremental: bool = False):
    positions, on_surface, previous = _rock()
    recompute = surface.near_changes(positions, positions[_eroded()], SURFACE_GRID) if incremental else None

    def work():
        _threads(threads)
        if incremental:
            return surface.normals(positions, on_surface, SURFACE_GRID, previous=previous,
                                   recompute=recompute)
        return surface.normals(positions, on_surface, SURFACE_GRID)

    return work, int(on_surface.sum()), "surface particles"


def wind_case(threads: int = 2):
    positions, on_surface, normals = _rock()
    k_a = np.full(len(positions), 1e-5)
    params = wind.WindParams(azimuth=270.0, speed=10.0)

    def work():
        _threads(threads)
        return wind.abrasion_rate(positions, normals, on_surface, SURFACE_GRID, k_a, params, SEED, 0)

    return work, int(on_surface.sum()), "surface particles"


def deflation_case(threads: int = 2):
    positions, on_surface, _ = _rock()
    k_d = np.full(len(positions), 1e-7)
    compression = np.random.default_rng(SEED).random(len(positions)) * 4e6
    params = deflation.DeflationParams()

    def work():
        _threads(threads)
        return deflation.deflation_rate(on_surface, k_d, compression, params)

    return work, len(positions), "particles"


def deposition_case(threads: int = 2):
    positions, _, _ = _rock()
    eroded = _eroded()
    kept = np.delete(positions, eroded, axis=0)
    grid = deposition.offset_grid(MPM_GRID, SEED, 0)
    params = deposition.DepositionParams()

    def work():
        _threads(threads)
        return deposition.deposit(positions[eroded], grid.occupancy(kept), grid, params, SEED, 0)

    return work, len(eroded), "eroded particles"


def support_case(threads: int = 2):
    """The block-fall test (``support.unsupported``) of the rock, after a frame's erosion of the
    tunnel's roof: the bridge over the tunnel is held by its piers only."""
    positions, _, _ = _rock()
    kept = np.delete(positions, _eroded(), axis=0)

    def work():
        _threads(threads)
        return support.unsupported(kept, SURFACE_GRID)

    return work, len(kept), "particles"


def fluvial_case(particles, lattice, threads: int = 2):
    """Water receivers, depression routing, discharge (rain and a source on the rock's top),
    the fluvial rate (k_t = 400 1/Pa, τ_c = 1 Pa) and the deposition of the frame's eroded
    particles (the 2000 surface particles nearest the top's centre) on ``lattice``'s MPM grid,
    for the ``particles`` of a rock (normals computed once, outside the timing)."""
    positions = particles.positions
    on_surface = surface.surface_particles(positions, lattice.surface_grid())
    normals = surface.normals(positions, on_surface, lattice.surface_grid())
    grid = lattice.mpm_grid()
    top = positions[:, 2].max()
    centre = np.array([*(np.asarray(lattice.low[:2]) + 0.5 * np.asarray(lattice.size[:2])), top])
    params = fluvial.FluvialParams(sources=((*centre[:2], top + 1.0, 1e6),))
    layer = np.zeros(len(positions), dtype=np.int32)
    k_t, tau_c = np.array([400.0]), np.array([1.0])
    index = np.flatnonzero(on_surface)
    eroded = index[np.argsort(np.linalg.norm(positions[index] - centre, axis=1))[:CHANGES]]
    kept = np.delete(positions, eroded, axis=0)
    depositing = deposition.DepositionParams()

    def work():
        _threads(threads)
        receivers = water_receivers.water_receivers(positions, grid, SEED, 0)
        water = discharge.discharge(basins.route_depressions(receivers), params.precipitation, params.sources)
        rate = fluvial.fluvial_rate(positions, normals, on_surface, layer, k_t, tau_c, water.q, grid, params)
        moved = deposition.offset_grid(grid, SEED, 0)
        return rate, deposition.deposit(positions[eroded], moved.occupancy(kept), moved, depositing, SEED, 0)

    return work, len(positions), "particles"
