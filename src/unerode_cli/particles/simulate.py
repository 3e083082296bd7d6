"""Particle erosion runs (003 §3–5): ``run`` emits particles iteration after iteration, traces
each batch against the terrain as it was at the start of the iteration, and applies the
particles' impacts in particle order. ``run_kinds`` does the same for several kinds of
particles at once (003 Fig. 8: rain, wind and a river in one run), each with its own
parameters, emission and medium velocity: within an iteration the kinds are traced in their
given order, every one against the terrain as it stood at the start of the iteration, and
their impacts applied kind after kind. ``ParticleIterations`` is such a run one iteration at
a time, whose state (``state`` / ``restore``: the terrain's arrays, ``terrain_state``, the
budget sums, counts and sampled paths) lets a stopped run go on bit for bit.

Determinism: a particle's random numbers come from its own stream keyed by (seed of its kind,
iteration, particle index) and the terrain is frozen while a batch is traced, so what a particle does does
not depend on the other particles nor on the threads; its impacts are then applied in a fixed
order. The result for a seed is bit-identical for any number of numba threads.

The numba kernels are imported on first use.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from typing import Any

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.particles.emission import Emission
from unerode_cli.particles.medium import STILL, VelocityField
from unerode_cli.particles.parameters import ParticleParams
from unerode_cli.particles.terrain import Material, Terrain, TracingSnapshot

#: Particles traced per kernel call (bounds the memory of the event buffers); any value gives
#: the same result, since impacts are applied in particle order against a frozen terrain.
BATCH = 16384
#: Size of the first batch of a run, which sizes the event buffers of the next ones.
PILOT = 1024
#: Points kept per sampled path (the last one is always the particle's final position).
MAX_PATH_POINTS = 4096
_FATES = ("settled", "edge", "expired")
#: When impacts alter the terrain: after each iteration, all the particles of the iteration
#: traced in parallel on the terrain as it stood before it; or at each impact (003 §3), the
#: particles traced one after the other, serially.
PER_ITERATION, PER_IMPACT = "per-iteration", "per-impact"
APPLY_MODES = (PER_ITERATION, PER_IMPACT)


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
        kinds: what each kind of particles did (one entry per kind of ``run_kinds``).
        iterations: the iterations run (fewer than asked when the run was cancelled).
    """

    terrain: Terrain
    elevation: np.ndarray
    dh: np.ndarray
    budget: ParticleBudget
    stats: ParticleStats
    paths: list[ParticlePath]
    kinds: tuple[KindRun, ...] = ()
    iterations: int = 0


@dataclass(frozen=True)
class ParticleKind:
    """One kind of particles of a run (003 Fig. 8: several phenomena at once).

    Attributes:
        params: its physical parameters (``k_eps`` and ``tau_c`` are those of a terrain
            without materials of its own).
        emission: where and how many of them start per iteration.
        velocity: the medium velocity field they feel (003 Eq. 8); None = still medium.
        name: a label for the results (e.g. the preset's name).
    """

    params: ParticleParams
    emission: Emission
    velocity: VelocityField | None = None
    name: str = ""


@dataclass(frozen=True)
class KindRun:
    """What one kind of particles did in a run: its ``name``, the volumes it moved (m³) and
    its counts."""

    name: str
    budget: ParticleBudget
    stats: ParticleStats


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


def kind_seed(seed: int, position: int) -> int:
    """The seed of the kind at ``position`` (0, 1, …) of a run with ``seed``: the seed itself for
    the first kind (so a run of one kind is ``run``'s), else a counter-based hash of the two
    (``physics.stream_key`` with an iteration no run reaches, kept to 63 bits as the kernels
    take it), so that the kinds' particles draw independent numbers."""
    if position == 0:
        return int(seed)
    from unerode_cli.particles.physics import stream_key

    return int(stream_key(np.uint64(seed), np.uint64(2**64 - 1), np.uint64(position))) >> 1


def run(terrain: Terrain, params: ParticleParams, emission: Emission, *, iterations: int = 1,
        seed: int = 0, velocity: VelocityField | None = None, sea_level: float | None = None,
        paths: int = 0, path_stride: int = 1,
        on_iteration: Callable[[int], None] | None = None, apply: str = PER_ITERATION) -> ParticleRun:
    """Erode ``terrain`` with particles (003 §3–4).

    Each iteration emits ``emission.count`` particles, traces all of them against the terrain
    as it stands (frozen during the iteration), then applies their impacts in particle order:
    003 Eq. 9 on a heightfield, Eq. 10 on layered terrains, Eq. 11 on implicit terrains, Eq. 13
    on density voxels and Eq. 14 on binary voxels. Particles die at the domain's edge
    (their load is lost), when settled (speed < ``rest_speed`` on the ground) or after their
    ``lifetime``; a dying particle deposits its load where it is, but for the fraction
    ``keep_suspended``.

    With ``apply`` ``PER_IMPACT`` (003 §3's order) each impact alters the terrain at once, so
    a particle meets what its own earlier impacts and every earlier particle did; the particles
    are then traced one after the other on one thread (serial, and deterministic too), at the
    cost of the parallel tracing. Heightfields and density and binary voxels only. Both modes
    conserve mass alike.

    Args:
        terrain: a ``HeightfieldTerrain``, ``LayeredTerrain``, ``DensityTerrain``,
            ``BinaryTerrain`` or ``SdfTerrain``; not modified.
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
        apply: ``PER_ITERATION`` (default) or ``PER_IMPACT``.

    Returns:
        The new terrain, its surface and change, the mass budget, counts and sampled paths.

    Raises:
        ValueError: a parameter out of range, an emission or velocity field that does not fit
            the grid, or bad run arguments (one sentence).
    """
    return run_kinds(terrain, (ParticleKind(params, emission, velocity),), iterations=iterations, seed=seed,
                     sea_level=sea_level, paths=paths, path_stride=path_stride, on_iteration=on_iteration,
                     apply=apply)


@dataclass
class _KindTracer:
    """A kind's kernel arguments and running totals in a run: its particles are numbered from
    ``offset`` within an iteration, ``sums`` holds the budget columns of each batch."""

    kind: ParticleKind
    seed: int
    offset: int
    phys: np.ndarray
    emission_arrays: tuple
    field_arrays: tuple
    default: Material
    capacity: int = 32
    sums: list[list[float]] = dataclass_field(default_factory=list)
    impacts: int = 0
    fates: np.ndarray = dataclass_field(default_factory=lambda: np.zeros(3, np.int64))

    @property
    def count(self) -> int:
        return int(self.kind.emission.count)

    @property
    def material_key(self) -> tuple[float, float]:
        return self.default.k_eps, self.default.tau_c


def _budget(batches: list[list[float]]) -> ParticleBudget:
    """The budget of per-batch sums (rows: batches, columns ``kernels.B_*``)."""
    from unerode_cli.particles import kernels

    total = [math.fsum(batch[k] for batch in batches) for k in range(kernels.N_BUDGET)]
    return ParticleBudget(
        emitted=total[kernels.B_EMITTED], detached=total[kernels.B_DETACHED],
        deposited=total[kernels.B_DEPOSITED], suspended=total[kernels.B_SUSPENDED],
        lost=total[kernels.B_LOST], dropped=total[kernels.B_DROPPED])


def _stats(particles: int, impacts: int, fates: np.ndarray) -> ParticleStats:
    return ParticleStats(particles, impacts, int(fates[0]), int(fates[1]), int(fates[2]))


def _tracers(kinds: Sequence[ParticleKind], grid: Grid, seed: int,
             sea_level: float | None) -> list[_KindTracer]:
    """The kinds checked against the grid, with their kernel arguments."""
    if not kinds:
        raise ValueError("a run needs at least one kind of particles")
    tracers = []
    offset = 0
    for position, kind in enumerate(kinds):
        velocity = STILL if kind.velocity is None else kind.velocity
        for part in (kind.params, kind.emission, velocity):
            part.validate(grid)
        default = Material(kind.name or "heightfield", kind.params.k_eps, kind.params.tau_c)
        tracers.append(_KindTracer(kind, kind_seed(seed, position), offset, _packed(kind.params, sea_level),
                                   kind.emission.kernel_arrays(grid), velocity.kernel_arrays(grid), default))
        offset += int(kind.emission.count)
    return tracers


class _Batches:
    """Traces a kind's particles of an iteration batch by batch and applies their impacts to
    the working terrain, sampling the chosen paths; keeps the event buffer between batches."""

    def __init__(self, work: Terrain, chosen: np.ndarray, per_iteration: int, path_stride: int,
                 between: Callable[[], None] | None = None) -> None:
        self.work, self.chosen = work, chosen
        self.per_iteration, self.path_stride = per_iteration, path_stride
        self.between = between
        self.buffer = np.empty((0, 0, 4))
        self.paths: list[ParticlePath] = []

    def run(self, tracer: _KindTracer, snap: TracingSnapshot, iteration: int,
            live: tuple | None = None) -> None:
        """Trace the kind's particles of ``iteration``; with ``live`` (``Terrain.live_state``)
        each impact alters the snapshot at once, and no events are kept nor applied."""
        from unerode_cli.particles import kernels

        live = kernels.live_off() if live is None else live
        per_impact = live[0] != kernels.LIVE_OFF
        grid = self.work.grid
        ekind, ecdf, ecells, epts, ev0 = tracer.emission_arrays
        frozen = (snap.surface, grid.valid, snap.material, snap.k_eps, snap.tau_c, grid.dx, grid.dy,
                  *snap.ground_arguments(), *tracer.field_arrays, ekind, ecdf, ecells, epts,
                  float(tracer.kind.emission.spread), ev0)
        for start, stop in _batches(tracer.count, first=PILOT if iteration == 0 else BATCH):
            if self.between is not None:
                self.between()
            indices = np.arange(start, stop, dtype=np.int64)
            slot = np.full(indices.size, -1, np.int64)
            picked = np.isin(iteration * self.per_iteration + tracer.offset + indices, self.chosen)
            slot[picked] = np.arange(picked.sum())
            path_buf = np.zeros((int(picked.sum()), MAX_PATH_POINTS, 4))
            rows, width = max(self.buffer.shape[0], indices.size), max(self.buffer.shape[1], tracer.capacity)
            if self.buffer.shape[:2] != (rows, width):
                self.buffer = np.empty((rows, width, 4))
            events, counts, radii, fates, n_imp, budget, path_len = kernels.trace_batch(
                indices, iteration, tracer.seed, tracer.phys, *frozen,
                np.empty((indices.size, 0, 4)) if per_impact else self.buffer[: indices.size], slot,
                path_buf, self.path_stride, live)
            over = np.flatnonzero(counts > (np.inf if per_impact else self.buffer.shape[1]))
            retraced_row = np.full(indices.size, -1, np.int64)
            retraced = np.zeros((0, 1, 4))
            if over.size:
                larger = np.empty((over.size, int(counts[over].max()), 4))
                retraced = kernels.trace_batch(indices[over], iteration, tracer.seed, tracer.phys, *frozen,
                                               larger, np.full(over.size, -1, np.int64), np.zeros((0, 1, 4)),
                                               self.path_stride, live)[0]
                retraced_row[over] = np.arange(over.size)
            if not per_impact:
                flat = kernels.flatten(events, counts, radii, retraced_row, retraced)
                self.work.apply(*(np.ascontiguousarray(flat[:, k]) for k in range(5)))
            typical = max(1.0, float(np.percentile(counts, 90)))
            tracer.capacity = int(min(1024, max(16, 2 ** math.ceil(math.log2(typical)))))
            tracer.sums.append([math.fsum(budget[:, k]) for k in range(kernels.N_BUDGET)])
            tracer.impacts += int(n_imp.sum())
            tracer.fates += np.bincount(fates, minlength=3)
            for i, s in zip(np.flatnonzero(picked), slot[picked], strict=True):
                self.paths.append(ParticlePath(iteration, int(tracer.offset + indices[i]),
                                               path_buf[s, : path_len[s]].copy(), _FATES[fates[i]]))


def run_kinds(terrain: Terrain, kinds: Sequence[ParticleKind], *, iterations: int = 1, seed: int = 0,
              sea_level: float | None = None, paths: int = 0, path_stride: int = 1,
              on_iteration: Callable[[int], None] | None = None, apply: str = PER_ITERATION,
              cancelled: Callable[[], bool] | None = None) -> ParticleRun:
    """Erode ``terrain`` with several kinds of particles at once (003 Fig. 8); ``run``'s
    arguments otherwise. ``cancelled`` is asked before each iteration: when it says True the
    run ends there and returns what the iterations before did (``ParticleRun.iterations``).

    Each iteration traces the kinds in their order, each against the terrain as it stood at
    the start of the iteration (one frozen snapshot per distinct K_ε, τ_c of the kinds), and
    applies their impacts kind after kind, in particle order. Kind j's particles draw from
    streams keyed by ``kind_seed(seed, j)``: what a kind does in one iteration is what ``run``
    does with that seed on the same terrain.

    With ``apply`` ``PER_IMPACT`` the kinds' particles are traced one after the other, each on
    the terrain as the impacts before it left it (see ``run``).

    The iterations are those of :class:`ParticleIterations`, which also runs them one at a time
    and saves and restores a run between them.

    Returns:
        As ``run``, with ``kinds`` the budget and counts of each kind; ``budget`` and ``stats``
        are their totals, and the paths are numbered within an iteration across the kinds
        (kind j's particle i is index Σ_{k<j} count_k + i).
    """
    steps = ParticleIterations(terrain, kinds, iterations=iterations, seed=seed, sea_level=sea_level,
                               paths=paths, path_stride=path_stride, apply=apply)
    while steps.done < iterations:
        if cancelled is not None and cancelled():
            break
        done = steps.iterate()
        if on_iteration is not None:
            on_iteration(done)
    return steps.result()


class ParticleIterations:
    """A run of ``run_kinds`` (same arguments, but the callbacks) one iteration at a time:
    ``iterate`` runs the next iteration, ``result`` gives what the iterations so far did, and
    ``state`` / ``restore`` save and take back everything the next iterations depend on, so
    that a run restored after ``done`` iterations goes on bit for bit as the run that saved it.

    The state (``state``): the altered terrain's arrays (``terrain_state``), each kind's budget
    sums per batch (m³, ``kernels.B_*`` columns), impact and fate counts and event capacity,
    the size of the event buffer, and the sampled paths. There is no random state to keep: a
    particle's numbers come from its own stream keyed by (seed of its kind, iteration, particle
    index).

    ``between_batches`` (no arguments) is called before each batch of particles is traced; it
    may raise to abandon the run there (e.g. on Ctrl-C), which leaves the iteration half done:
    the run is then only good for ``restore`` from an earlier ``state``.
    """

    def __init__(self, terrain: Terrain, kinds: Sequence[ParticleKind], *, iterations: int = 1, seed: int = 0,
                 sea_level: float | None = None, paths: int = 0, path_stride: int = 1,
                 apply: str = PER_ITERATION, between_batches: Callable[[], None] | None = None) -> None:
        _check_run_args(iterations, seed, paths, path_stride, sea_level)
        if apply not in APPLY_MODES:
            raise ValueError(f"impacts apply {' or '.join(APPLY_MODES)}, not {apply!r}")
        self.terrain, self.iterations, self.apply = terrain, iterations, apply
        self.tracers = _tracers(kinds, terrain.grid, seed, sea_level)
        per_iteration = sum(t.count for t in self.tracers)
        total = iterations * per_iteration
        chosen = np.unique(np.arange(min(paths, total), dtype=np.int64) * total // max(paths, 1))
        self.work = terrain.copy()
        self.batches = _Batches(self.work, chosen, per_iteration, path_stride, between_batches)
        #: iterations done
        self.done = 0

    def iterate(self) -> int:
        """Run the next iteration (``done``, 0-based); returns the iterations done."""
        iteration, work = self.done, self.work
        if iteration >= self.iterations:
            raise ValueError(f"the run has done its {self.iterations} iterations")
        snapshots: dict[tuple[float, float], TracingSnapshot] = {}
        for tracer in self.tracers:  # all taken before any kind alters the terrain
            if self.apply == PER_ITERATION and tracer.material_key not in snapshots:
                snapshots[tracer.material_key] = work.tracing_snapshot(tracer.default)
        for tracer in self.tracers:
            if self.apply == PER_IMPACT:  # on the terrain as the impacts before left it
                snap = work.tracing_snapshot(tracer.default)
                live = work.live_state(snap)
                self.batches.run(tracer, snap, iteration, live)
                work.absorb(snap, live)
            else:
                self.batches.run(tracer, snapshots[tracer.material_key], iteration)
        self.done = iteration + 1
        return self.done

    def result(self) -> ParticleRun:
        """What the iterations done so far did (its ``terrain`` is the run's working terrain)."""
        grid, done, tracers = self.terrain.grid, self.done, self.tracers
        new_surface = self.work.surface()
        dh = np.where(grid.valid, new_surface - self.terrain.surface(), 0.0)
        by_kind = tuple(KindRun(t.kind.name, _budget(t.sums), _stats(done * t.count, t.impacts, t.fates))
                        for t in tracers)
        fates = np.sum([t.fates for t in tracers], axis=0)
        stats = _stats(done * sum(t.count for t in tracers), sum(t.impacts for t in tracers), fates)
        budget = _budget([batch for t in tracers for batch in t.sums])
        return ParticleRun(self.work, new_surface, dh, budget, stats, list(self.batches.paths), by_kind, done)

    def state(self) -> dict[str, Any]:
        """The run after ``done`` iterations: NumPy arrays and JSON values (numbers, text, lists)
        under names of their own, the terrain's under ``terrain.*``."""
        from unerode_cli.particles import kernels

        paths = self.batches.paths
        state: dict[str, Any] = {
            "iterations_done": self.done,
            "event_buffer": list(self.batches.buffer.shape[:2]),
            "kinds": [{"capacity": t.capacity, "impacts": t.impacts, "fates": [int(n) for n in t.fates]}
                      for t in self.tracers],
            "paths": [[p.iteration, p.index, len(p.points), p.fate] for p in paths],
            "path_points": np.concatenate([p.points for p in paths]) if paths else np.zeros((0, 4)),
            **terrain_state(self.work),
        }
        for j, tracer in enumerate(self.tracers):
            state[f"kind{j}_sums"] = np.array(tracer.sums, dtype=np.float64).reshape(-1, kernels.N_BUDGET)
        return state

    def restore(self, state: dict[str, Any]) -> None:
        """Take back a state that ``state`` gave (of a run with the same arguments)."""
        kinds = state["kinds"]
        if len(kinds) != len(self.tracers):
            raise ValueError(f"the state has {len(kinds)} kinds of particles, the run {len(self.tracers)}")
        self.done = int(state["iterations_done"])
        rows, width = (int(n) for n in state["event_buffer"])
        self.batches.buffer = np.empty((rows, width, 4))
        for j, (tracer, saved) in enumerate(zip(self.tracers, kinds, strict=True)):
            tracer.capacity, tracer.impacts = int(saved["capacity"]), int(saved["impacts"])
            tracer.fates = np.array(saved["fates"], dtype=np.int64)
            tracer.sums = [[float(v) for v in row] for row in np.asarray(state[f"kind{j}_sums"])]
        points = np.asarray(state["path_points"], dtype=np.float64)
        ends = np.cumsum([0] + [int(p[2]) for p in state["paths"]])
        self.batches.paths = [ParticlePath(int(i), int(index), points[start:stop].copy(), str(fate))
                              for (i, index, _, fate), start, stop
                              in zip(state["paths"], ends[:-1], ends[1:], strict=True)]
        restore_terrain(self.work, state)


def terrain_state(terrain: Terrain) -> dict[str, Any]:
    """What a terrain particles alter holds that a run changes, under ``terrain.*`` names:
    the heights of a heightfield (m); the base (m), layer thicknesses (m) and layer materials
    of a layered terrain; the densities or solid flags and hit counts, the material index and
    what left the grid (m³) or the hit counters of voxels; the node cache (m), the pending
    metaballs and the flattened base of an implicit terrain."""
    from unerode_cli.particles.sdf_terrain import SdfTerrain
    from unerode_cli.particles.terrain import HeightfieldTerrain, LayeredTerrain
    from unerode_cli.particles.voxel_terrain import BinaryTerrain, DensityTerrain, VoxelTerrain

    state: dict[str, Any] = {}
    if isinstance(terrain, HeightfieldTerrain):
        state["terrain.heights"] = terrain._h
    elif isinstance(terrain, LayeredTerrain):
        state.update({"terrain.base": terrain._base, "terrain.thickness": terrain._thickness,
                      "terrain.layer_material": terrain._layer_material})
    elif isinstance(terrain, VoxelTerrain):
        if terrain.voxels.material is not None:
            state["terrain.material"] = terrain.voxels.material
        if isinstance(terrain, DensityTerrain):
            state.update({"terrain.density": terrain.voxels.density, "terrain.left": terrain.left})
        elif isinstance(terrain, BinaryTerrain):
            state.update({"terrain.solid": terrain.voxels.solid, "terrain.hits": terrain.voxels.hits,
                          "terrain.counters": [int(n) for n in terrain.counters]})
    elif isinstance(terrain, SdfTerrain):
        state.update({"terrain.cache": terrain.field.cache, "terrain.balls": terrain.field.balls,
                      "terrain.flattened": terrain.field.base.grid})
    if not state:
        raise ValueError(f"a {type(terrain).__name__} cannot be saved")
    return state


def restore_terrain(terrain: Terrain, state: dict[str, Any]) -> None:
    """Put a ``terrain_state`` back into ``terrain``, a copy of the terrain the run began with
    (arrays written in place, so that their types and what refers to them stay)."""
    from unerode_cli.particles.sdf_terrain import SdfTerrain
    from unerode_cli.particles.terrain import HeightfieldTerrain, LayeredTerrain
    from unerode_cli.particles.voxel_terrain import BinaryTerrain, DensityTerrain, VoxelTerrain

    if isinstance(terrain, HeightfieldTerrain):
        _put(terrain._h, state["terrain.heights"])
    elif isinstance(terrain, LayeredTerrain):
        for target, name in ((terrain._base, "base"), (terrain._thickness, "thickness"),
                             (terrain._layer_material, "layer_material")):
            _put(target, state[f"terrain.{name}"])
    elif isinstance(terrain, VoxelTerrain):
        if terrain.voxels.material is not None:
            _put(terrain.voxels.material, state["terrain.material"])
        if isinstance(terrain, DensityTerrain):
            _put(terrain.voxels.density, state["terrain.density"])
            terrain.left = float(state["terrain.left"])
        elif isinstance(terrain, BinaryTerrain):
            _put(terrain.voxels.solid, state["terrain.solid"])
            _put(terrain.voxels.hits, state["terrain.hits"])
            terrain.counters[...] = np.array(state["terrain.counters"], dtype=np.int64)
    elif isinstance(terrain, SdfTerrain):
        from unerode_cli.volume.sdf_field import Base

        field = terrain.field
        _put(field.cache, state["terrain.cache"])
        field.balls = np.array(state["terrain.balls"], dtype=np.float64, order="C")
        flattened = np.asarray(state["terrain.flattened"])
        if flattened.size:
            field.base = Base.of_grid(flattened)
    else:
        raise ValueError(f"a {type(terrain).__name__} cannot be restored")


def _put(target: np.ndarray, saved: np.ndarray) -> None:
    """Write ``saved`` into ``target`` (same shape)."""
    saved = np.asarray(saved)
    if saved.shape != target.shape:
        raise ValueError(f"a saved array of shape {saved.shape} does not fit the terrain's {target.shape}")
    target[...] = saved
