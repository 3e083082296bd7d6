"""Particle erosion runs (003 §3–5): ``run`` emits particles iteration after iteration, traces
each batch against the terrain as it was at the start of the iteration, and applies the
particles' impacts in particle order.

Determinism: a particle's random numbers come from its own stream keyed by (seed, iteration,
particle index) and the terrain is frozen while a batch is traced, so what a particle does does
not depend on the other particles nor on the threads; its impacts are then applied in a fixed
order. The result for a seed is bit-identical for any number of numba threads.

The numba kernels are imported on first use.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from unerode_cli.particles.emission import Emission
from unerode_cli.particles.medium import STILL, VelocityField
from unerode_cli.particles.parameters import ParticleParams
from unerode_cli.particles.terrain import Material, Terrain

#: Particles traced per kernel call (bounds the memory of the event buffers); any value gives
#: the same result, since impacts are applied in particle order against a frozen terrain.
BATCH = 16384
#: Size of the first batch of a run, which sizes the event buffers of the next ones.
PILOT = 1024
#: Points kept per sampled path (the last one is always the particle's final position).
MAX_PATH_POINTS = 4096
_FATES = ("settled", "edge", "expired")


@dataclass(frozen=True)
class ParticleBudget:
    """Volumes moved by a run (m³).

    Attributes:
        emitted: carried in by the particles at emission (``initial_load``, e.g. the volcano
            preset): matter added by design.
        detached: taken from the terrain at impacts (003 Eq. 3).
        deposited: put onto the terrain, at impacts (003 Eq. 4) and where particles died.
        dropped: the part of ``deposited`` left where particles died (settled or expired).
        suspended: kept in suspension by dying particles (``keep_suspended``, e.g. the coastal
            preset's corrosion): matter removed by design.
        lost: carried out of the domain by particles leaving it.

    The terrain's volume changes by deposited − detached, and
    emitted + detached − deposited − suspended − lost = 0 (``residual``, up to rounding).
    """

    emitted: float
    detached: float
    deposited: float
    suspended: float
    lost: float
    dropped: float

    @property
    def residual(self) -> float:
        """emitted + detached − deposited − suspended − lost (m³), 0 up to rounding."""
        return self.emitted + self.detached - self.deposited - self.suspended - self.lost


@dataclass(frozen=True)
class ParticleStats:
    """Counts of a run: particles traced, impacts with the ground, and how particles died."""

    particles: int
    impacts: int
    settled: int
    lost: int
    expired: int


@dataclass(frozen=True)
class ParticlePath:
    """A sampled particle path.

    Attributes:
        iteration, index: which particle.
        points: float64[k, 4]: column, row (grid coordinates, cell centres at integers; a
            raster transform maps (column + 0.5, row + 0.5) to map coordinates), z (m) and the
            time since emission (s).
        fate: ``"settled"``, ``"edge"`` (left the domain) or ``"expired"`` (end of lifetime).
    """

    iteration: int
    index: int
    points: np.ndarray
    fate: str


@dataclass(frozen=True)
class ParticleRun:
    """What ``run`` returns.

    Attributes:
        terrain: the altered terrain (a new object; the input is untouched).
        elevation: its ground surface float64[ny, nx] (m).
        dh: elevation change float64[ny, nx] (m), 0 on nodata cells.
        budget: the volumes moved (m³).
        stats: particle and impact counts.
        paths: the sampled paths, in particle order.
    """

    terrain: Terrain
    elevation: np.ndarray
    dh: np.ndarray
    budget: ParticleBudget
    stats: ParticleStats
    paths: list[ParticlePath]


def _packed(params: ParticleParams, sea_level: float | None) -> np.ndarray:
    """The parameter vector of the kernels (indices ``physics.P_*``)."""
    from unerode_cli.particles import physics as ph

    values = {
        ph.P_RADIUS: params.radius, ph.P_RADIUS_MAX: params.radius_max, ph.P_DENSITY: params.density,
        ph.P_RESTITUTION: params.restitution, ph.P_CAPACITY: params.capacity,
        ph.P_INITIAL_LOAD: params.initial_load, ph.P_EXPONENT: params.erosion_exponent,
        ph.P_SHEAR_K: params.shear_k, ph.P_SHEAR_LENGTH: params.shear_length, ph.P_OMEGA: params.omega,
        ph.P_HINDERED: params.hindered_exponent, ph.P_STRENGTH: params.strength,
        ph.P_RHO_AIR: params.rho_air, ph.P_RHO_WATER: params.rho_water, ph.P_MU_AIR: params.mu_air,
        ph.P_MU_WATER: params.mu_water, ph.P_GRAVITY: params.gravity, ph.P_ALPHA: params.field_strength,
        ph.P_DT: params.dt, ph.P_LIFETIME: params.lifetime, ph.P_REST_SPEED: params.rest_speed,
        ph.P_DROP_HEIGHT: params.drop_height, ph.P_KEEP_SUSPENDED: params.keep_suspended,
        ph.P_SEA_LEVEL: -math.inf if sea_level is None else float(sea_level),
    }
    packed = np.empty(ph.N_PARAMS)
    for index, value in values.items():
        packed[index] = value
    return packed


def _batches(count: int, first: int) -> list[tuple[int, int]]:
    """(start, stop) of the batches of ``count`` particles, the first one of ``first``."""
    bounds = [0, *range(min(first, count), count, BATCH), count]
    return list(zip(bounds[:-1], bounds[1:], strict=True))


def _check_run_args(iterations: int, seed: int, paths: int, path_stride: int,
                    sea_level: float | None) -> None:
    counts = (("iterations", iterations, 1), ("paths", paths, 0), ("path_stride", path_stride, 1))
    for name, value, low in counts:
        if int(value) != value or value < low:
            raise ValueError(f"{name} must be an integer ≥ {low}, got {value}")
    if int(seed) != seed or not 0 <= seed < 2**64:
        raise ValueError(f"the seed must be an integer in [0, 2^64), got {seed}")
    if sea_level is not None and not np.isfinite(sea_level):
        raise ValueError(f"the sea level must be finite (m), got {sea_level}")


def run(terrain: Terrain, params: ParticleParams, emission: Emission, *, iterations: int = 1,
        seed: int = 0, velocity: VelocityField | None = None, sea_level: float | None = None,
        paths: int = 0, path_stride: int = 1,
        on_iteration: Callable[[int], None] | None = None) -> ParticleRun:
    """Erode ``terrain`` with particles (003 §3–4).

    Each iteration emits ``emission.count`` particles, traces all of them against the terrain
    as it stands (frozen during the iteration), then applies their impacts in particle order:
    003 Eq. 9 on a heightfield, Eq. 10 on layered terrains, Eq. 13 on density voxels and Eq. 14
    on binary voxels. Particles die at the domain's edge
    (their load is lost), when settled (speed < ``rest_speed`` on the ground) or after their
    ``lifetime``; a dying particle deposits its load where it is, but for the fraction
    ``keep_suspended``.

    Args:
        terrain: a ``HeightfieldTerrain``, ``LayeredTerrain``, ``DensityTerrain`` or
            ``BinaryTerrain``; not modified.
        params: physical parameters (``ParticleParams``; ``presets.preset_params`` builds them
            from 003 Table 1). ``k_eps`` and ``tau_c`` are the heightfield's material.
        emission: where and how many particles start per iteration.
        iterations: number of iterations (≥ 1).
        seed: random seed (integer in [0, 2^64)).
        velocity: medium velocity field (003 Eq. 8); None = still medium.
        sea_level: elevation (m) below which the medium is water (ρ_water, μ_water), above it
            air; None = air everywhere.
        paths: number of particle paths to sample, evenly over the run's particles.
        path_stride: record a sampled path every this many steps (and at death).
        on_iteration: called with the number of finished iterations after each one (progress).

    Returns:
        The new terrain, its surface and change, the mass budget, counts and sampled paths.

    Raises:
        ValueError: a parameter out of range, an emission or velocity field that does not fit
            the grid, or bad run arguments (one sentence).
    """
    from unerode_cli.particles import kernels

    grid = terrain.grid
    params.validate(grid)
    emission.validate(grid)
    velocity = STILL if velocity is None else velocity
    velocity.validate(grid)
    _check_run_args(iterations, seed, paths, path_stride, sea_level)
    phys = _packed(params, sea_level)
    ekind, ecdf, ecells, epts, ev0 = emission.kernel_arrays(grid)
    fkind, fmedium, fscal, fbands = velocity.kernel_arrays(grid)
    default = Material("heightfield", params.k_eps, params.tau_c)
    count = int(emission.count)
    total = iterations * count
    chosen = np.unique(np.arange(min(paths, total), dtype=np.int64) * total // max(paths, 1))
    work = terrain.copy()
    capacity = 32
    buffer = np.empty((0, 0, 4))  # event rows of a batch, kept from batch to batch
    sums: list[list[float]] = [[] for _ in range(kernels.N_BUDGET)]
    impacts = 0
    fate_counts = np.zeros(3, np.int64)
    sampled: list[ParticlePath] = []
    for iteration in range(iterations):
        snap = work.tracing_snapshot(default)
        frozen = (snap.surface, grid.valid, snap.material, snap.k_eps, snap.tau_c, grid.dx, grid.dy,
                  *snap.ground_arguments(), fkind, fmedium, fscal, fbands, ekind, ecdf, ecells, epts,
                  float(emission.spread), ev0)
        for start, stop in _batches(count, first=PILOT if iteration == 0 else BATCH):
            indices = np.arange(start, stop, dtype=np.int64)
            numbers = iteration * count + indices
            slot = np.full(indices.size, -1, np.int64)
            picked = np.isin(numbers, chosen)
            slot[picked] = np.arange(picked.sum())
            path_buf = np.zeros((int(picked.sum()), MAX_PATH_POINTS, 4))
            if buffer.shape[0] < indices.size or buffer.shape[1] < capacity:
                buffer = np.empty((max(buffer.shape[0], indices.size), max(buffer.shape[1], capacity), 4))
            events, counts, radii, fates, n_imp, budget, path_len = kernels.trace_batch(
                indices, iteration, seed, phys, *frozen, buffer[: indices.size], slot, path_buf, path_stride)
            over = np.flatnonzero(counts > buffer.shape[1])
            retraced_row = np.full(indices.size, -1, np.int64)
            retraced = np.zeros((0, 1, 4))
            if over.size:
                larger = np.empty((over.size, int(counts[over].max()), 4))
                retraced = kernels.trace_batch(indices[over], iteration, seed, phys, *frozen, larger,
                                               np.full(over.size, -1, np.int64), np.zeros((0, 1, 4)),
                                               path_stride)[0]
                retraced_row[over] = np.arange(over.size)
            flat = kernels.flatten(events, counts, radii, retraced_row, retraced)
            work.apply(*(np.ascontiguousarray(flat[:, k]) for k in range(5)))
            capacity = int(min(1024, max(16, 2 ** math.ceil(math.log2(max(1.0, np.percentile(counts, 90)))))))
            for k in range(kernels.N_BUDGET):
                sums[k].append(math.fsum(budget[:, k]))
            impacts += int(n_imp.sum())
            fate_counts += np.bincount(fates, minlength=3)
            for i, s in zip(np.flatnonzero(picked), slot[picked], strict=True):
                sampled.append(ParticlePath(iteration, int(indices[i]), path_buf[s, : path_len[s]].copy(),
                                            _FATES[fates[i]]))
        if on_iteration is not None:
            on_iteration(iteration + 1)
    new_surface = work.surface()
    dh = np.where(grid.valid, new_surface - terrain.surface(), 0.0)
    total_of = [math.fsum(column) for column in sums]
    budget_total = ParticleBudget(
        emitted=total_of[kernels.B_EMITTED], detached=total_of[kernels.B_DETACHED],
        deposited=total_of[kernels.B_DEPOSITED], suspended=total_of[kernels.B_SUSPENDED],
        lost=total_of[kernels.B_LOST], dropped=total_of[kernels.B_DROPPED])
    stats = ParticleStats(total, impacts, int(fate_counts[0]), int(fate_counts[1]), int(fate_counts[2]))
    return ParticleRun(work, new_surface, dh, budget_total, stats, sampled)
