"""The frame loop of the sandstone simulator (002 Alg. 1).

Each frame, in the paper's order: (1) stress by MLS-MPM (warm-started; the first frame settles
from the lithostatic guess) and the erodibility it implies (Eq. 2); (2) surface particles and
their normals, recomputed only near last frame's changes (§5.1); (3) wind: deflation (Eq. 12)
and abrasion (Eq. 8); (4) the fluvial rate F, zero until fluvial erosion runs (§6); (5) erosion
(Eq. 1) of the surface particles; (6) deposition (§7) of what eroded: each eroded particle is
either deposited on a stable cell or exported out of the domain.

Deposits eroded again are exported: 002 §7 deposits the rock's debris and "neglect[s] smaller
sand grains and their transport by wind, as they are carried away from our domain", and a
deposit worn down to b ≤ 0 (Table 1 gives most deposits b = 0, so any erosion does it) is such
sand. Re-depositing it would put it back on the stable cell it came from, frame after frame,
burying the rock's foot under debris that never leaves.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from unerode_cli.sandstone import deflation, deposition, surface, viability, wind
from unerode_cli.sandstone.layers import LayerStack, Rock
from unerode_cli.sandstone.mpm import MpmParams, Relaxation, StressSolver, lithostatic_guess
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.sampling import Lattice

#: The stages of a frame, in order (their wall times are reported per frame).
STAGES = ("stress", "normals", "wind", "fluvial", "erosion", "deposition")


@dataclass(frozen=True)
class Processes:
    """Which processes run (the ablations of 002 §8.4); without ``stress`` the interlocking
    threshold is infinite (nothing interlocks), the stress itself is still computed for Eq. 12."""

    abrasion: bool = True
    deflation: bool = True
    deposition: bool = True
    stress: bool = True


@dataclass(frozen=True)
class SimulationParams:
    """Everything a run needs besides the particles: ``dt`` the frame's time step (years, 002
    Table 2: 1000), the stress solver, the wind, deflation and deposition parameters, the
    processes that run, and ``neighbours`` the k of the normals (002 §5.1: 20)."""

    dt: float = 1000.0
    mpm: MpmParams = field(default_factory=MpmParams)
    wind: wind.WindParams = field(default_factory=wind.WindParams)
    deflation: deflation.DeflationParams = field(default_factory=deflation.DeflationParams)
    deposition: deposition.DepositionParams = field(default_factory=deposition.DepositionParams)
    processes: Processes = field(default_factory=Processes)
    neighbours: int = 20

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0.0):
            raise ValueError(f"the time step must be a positive number of years, got {self.dt}")


@dataclass(frozen=True)
class FrameStats:
    """One frame's record: counts (``removed`` = ``deposited`` + ``exported``), the share of
    interlocked particles, the largest compressive stress (Pa), the MPM's work and the wall
    time of each stage (s)."""

    frame: int
    particles: int
    eroded: int
    deposited: int
    exported: int
    surface: int
    interlocked_share: float
    max_stress: float
    mpm_substeps: int
    mpm_residual: float
    seconds: dict[str, float]


class Simulation:
    """A run from ``particles`` (changed in place frame by frame) on the ``lattice``'s grids.

    ``frame`` counts the frames already done (0 for a new run, the snapshot's for a resumed
    one); ``seed`` keys every random choice with the frame, so a resumed run continues as the
    uninterrupted one would.
    """

    def __init__(self, particles: Particles, layers: LayerStack, rock: Rock, lattice: Lattice,
                 params: SimulationParams, seed: int = 0, frame: int = 0):
        self.particles, self.layers, self.rock, self.params = particles, layers, rock, params
        self.seed, self.frame = seed, frame
        self.surface_grid = lattice.surface_grid()
        #: deposition counts the rock on the MPM grid (8 particles a cell): on the surface grid
        #: (one a cell) a pile's heights come in whole cells and its flanks stand at ~45°
        #: whatever the angle of repose (``deposition``'s module docstring)
        self.deposition_grid = lattice.mpm_grid()
        self.spacing = lattice.spacing
        self.solver = StressSolver(lattice.mpm_grid(), rock, lattice.spacing**3, params.mpm)
        self.k_w, self.k_s = layers.table("k_w"), layers.table("k_s")
        self.threshold = layers.table("interlocking")
        if not params.processes.stress:
            self.threshold = np.full(len(self.k_w), np.inf)
        self.k_a, self.k_d = layers.table("k_a"), layers.table("k_d")
        self.changes = np.zeros((0, 3))
        self.last_relaxation: Relaxation | None = None

    def step(self) -> FrameStats:
        """Run one frame (module docstring) and return its record."""
        seconds: dict[str, float] = {}
        clock = time.perf_counter()

        def lap(stage: str) -> None:
            nonlocal clock
            now = time.perf_counter()
            seconds[stage] = now - clock
            clock = now

        p, params = self.particles, self.params
        relaxation = self._stress()
        rate, p.interlocked = viability.erodibility(p.layer, p.erodibility, p.stress, self.k_w, self.k_s,
                                                    self.threshold)
        lap("stress")
        on_surface = surface.surface_particles(p.positions, self.surface_grid)
        recompute = surface.near_changes(p.positions, self.changes, self.surface_grid)
        p.normals = surface.normals(p.positions, on_surface, self.surface_grid, params.neighbours,
                                    previous=p.normals, recompute=recompute)
        lap("normals")
        rates = np.zeros(len(p))
        if params.processes.deflation:
            rates += deflation.deflation_rate(on_surface, self.k_d[p.layer], p.stress, params.deflation)
        if params.processes.abrasion:
            rates += wind.abrasion_rate(p.positions, p.normals, on_surface, self.surface_grid,
                                        self.k_a[p.layer],
                                        params.wind, self.seed, self.frame)
        lap("wind")
        fluvial = np.zeros(len(p))
        lap("fluvial")
        eroded = viability.erode(p.viability, on_surface, rate, rates, fluvial, params.dt)
        lap("erosion")
        removed = p.positions[eroded]
        placed = self._deposit(p.positions[eroded & ~p.deposit], p.select(~eroded))
        lap("deposition")
        self.changes = np.concatenate([removed, placed])
        self.frame += 1
        return FrameStats(
            frame=self.frame, particles=len(self.particles), eroded=len(removed), deposited=len(placed),
            exported=len(removed) - len(placed), surface=int(on_surface.sum()),
            interlocked_share=float(p.interlocked.mean()) if len(p) else 0.0,
            max_stress=float(p.stress.max()) if len(p) else 0.0, mpm_substeps=relaxation.substeps,
            mpm_residual=relaxation.residual, seconds=seconds)

    def _stress(self) -> Relaxation:
        """Relax the MPM state: the first frame of a run settles (from the lithostatic guess)."""
        mpm = self.params.mpm
        first = self.last_relaxation is None and self.frame == 0
        if first and mpm.lithostatic:
            lithostatic_guess(self.particles, self.surface_grid, self.rock, self.spacing)
        self.last_relaxation = self.solver.relax(self.particles,
                                                 mpm.settle_substeps if first else mpm.substeps)
        return self.last_relaxation

    def _deposit(self, removed: np.ndarray, kept: Particles) -> np.ndarray:
        """Replace the particles by ``kept`` plus the deposits of the rock particles ``removed``;
        returns where the deposits were placed (the rest were exported)."""
        if not self.params.processes.deposition or len(removed) == 0:
            self.particles = kept
            return np.zeros((0, 3))
        grid = deposition.offset_grid(self.deposition_grid, self.seed, self.frame)
        placed, _ = deposition.deposit(removed, grid.occupancy(kept.positions), grid, self.params.deposition,
                                       self.seed, self.frame)
        new = Particles.new(placed, np.full(len(placed), self.layers.deposit_index),
                            viability=self.params.deposition.deposit_viability, deposit=True)
        self.particles = kept.appended(new)
        return placed
