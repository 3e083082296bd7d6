"""The frame loop of the sandstone simulator (002 Alg. 1).

Each frame, in the paper's order: (1) stress by MLS-MPM (warm-started; the first frame settles
from the lithostatic guess) and the erodibility it implies (Eq. 2); (2) surface particles and
their normals, recomputed only near last frame's changes (§5.1); (3) wind: deflation (Eq. 12)
and abrasion (Eq. 8), by rays (``wind``) or by the flow around the rock (``wind_flow``);
(4) fluvial: the water's receivers on the MPM grid (§6.2, Fig. 4, ``water_receivers``),
depression routing (``basins``), the discharge (``discharge``) and the fluvial rate F of Eq. 14
(``fluvial``), skipped (F = 0) when no layer has k_t > 0; (5) erosion
(Eq. 1) of the surface particles, the wind and fluvial rates shielded by the vegetation cover
(§8.3, ``vegetation``), which then grows on the deposits that stayed; (6) deposition (§7) of
what eroded: each eroded particle is either deposited on a stable cell or exported out of the
domain (also when it would land in the part of §7's offset grid that overhangs the domain);
(7) block fall (002 Fig. 3): a piece of rock that erosion cut off the ground falls and is laid
as debris by the same deposition (``support``).

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

from unerode_cli.sandstone import (
    basins,
    deflation,
    deposition,
    discharge,
    fluvial,
    mpm_settle,
    support,
    surface,
    vegetation,
    viability,
    water_receivers,
    wind,
    wind_flow,
)
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
    fluvial: bool = True


@dataclass(frozen=True)
class SimulationParams:
    """Everything a run needs besides the particles: ``dt`` the frame's time step (years, 002
    Table 2: 1000), the stress solver, the wind (and, for ``wind.model`` "flow", the flow's
    ``flow``), deflation, deposition and vegetation parameters,
    the processes that run, and ``neighbours`` the k of the normals (002 §5.1: 20)."""

    dt: float = 1000.0
    mpm: MpmParams = field(default_factory=MpmParams)
    wind: wind.WindParams = field(default_factory=wind.WindParams)
    deflation: deflation.DeflationParams = field(default_factory=deflation.DeflationParams)
    deposition: deposition.DepositionParams = field(default_factory=deposition.DepositionParams)
    vegetation: vegetation.VegetationParams = field(default_factory=vegetation.VegetationParams)
    flow: wind_flow.FlowWindParams = field(default_factory=wind_flow.FlowWindParams)
    fluvial: fluvial.FluvialParams = field(default_factory=fluvial.FluvialParams)
    processes: Processes = field(default_factory=Processes)
    neighbours: int = 20

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0.0):
            raise ValueError(f"the time step must be a positive number of years, got {self.dt}")


@dataclass(frozen=True)
class FrameStats:
    """One frame's record: counts (``removed`` = ``deposited`` + ``exported``), the share of
    interlocked particles, the largest compressive stress (Pa), the MPM's work, the wall
    time of each stage (s), the eroded particles whose fluvial rate exceeded their wind rate
    (``eroded_fluvial``) and the largest discharge of a cell (m³/y; 0 when fluvial erosion did
    not run), the particles of pieces cut off the ground that fell (``fallen``; ``fallen_landed``
    of them laid as debris, the rest left the domain), and the first frame's coarse MPM substeps
    in fine-substep equivalents (``mpm_coarse_cost``, ``mpm_settle``; 0 in later frames)."""

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
    eroded_fluvial: int
    discharge_max: float
    fallen: int = 0
    fallen_landed: int = 0
    mpm_coarse_cost: float = 0.0


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
        self.k_t, self.tau_c = layers.table("k_t"), layers.table("tau_c")
        #: water is routed on the MPM grid, 002 §6.2's "3D regular grid aligned to the one used
        #: for the MPM stress evaluation"
        self.water_grid = lattice.mpm_grid()
        self.changes = np.zeros((0, 3))
        self.last_relaxation: Relaxation | None = None
        self.flows: list[wind_flow.FlowWind] | None = None

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
        if params.processes.abrasion and params.wind.model == "flow":
            rates += self._flow_abrasion(on_surface)
        elif params.processes.abrasion:
            rates += wind.abrasion_rate(p.positions, p.normals, on_surface, self.surface_grid,
                                        self.k_a[p.layer],
                                        params.wind, self.seed, self.frame)
        lap("wind")
        fluvial_rate, discharge_max = np.zeros(len(p)), 0.0
        if params.processes.fluvial and np.any(self.k_t > 0.0):
            fluvial_rate, discharge_max = self._fluvial(on_surface)
        lap("fluvial")
        shield = vegetation.shielding(p.vegetation, params.vegetation.shield)
        eroded = viability.erode(p.viability, on_surface, rate, rates * shield, fluvial_rate * shield,
                                 params.dt)
        # eroded deposits are dropped below, so the cover grows on those that stayed (§8.3)
        p.vegetation = vegetation.grow(p.vegetation, p.deposit & on_surface, params.vegetation.growth,
                                       params.dt)
        lap("erosion")
        removed = p.positions[eroded]
        placed = self._deposit(p.positions[eroded & ~p.deposit], p, np.flatnonzero(~eroded))
        falls = support.unsupported(self.particles.positions, self.surface_grid)
        fell = self.particles.positions[falls]
        landed = (self._deposit(fell, self.particles, np.flatnonzero(~falls)) if len(fell)
                  else np.zeros((0, 3)))
        lap("deposition")
        self.changes = np.concatenate([removed, placed, fell, landed])
        self.frame += 1
        return FrameStats(
            frame=self.frame, particles=len(self.particles), eroded=len(removed), deposited=len(placed),
            exported=len(removed) - len(placed), surface=int(on_surface.sum()),
            interlocked_share=float(p.interlocked.mean()) if len(p) else 0.0,
            max_stress=float(p.stress.max()) if len(p) else 0.0, mpm_substeps=relaxation.substeps,
            mpm_residual=relaxation.residual, seconds=seconds,
            eroded_fluvial=int(np.count_nonzero(eroded & (fluvial_rate > rates))),
            discharge_max=discharge_max, fallen=len(fell), fallen_landed=len(landed),
            mpm_coarse_cost=relaxation.coarse_cost)

    def _flow_abrasion(self, on_surface: np.ndarray) -> np.ndarray:
        """Abrasion by the local wind of the flow around the rock (``wind_flow``), one flow per
        wind of the rose, updated every ``flow.every`` frames."""
        p, params = self.particles, self.params
        winds = wind.prevailing(params.wind)
        if self.flows is None:
            self.flows = [wind_flow.FlowWind(p.positions, w.blowing, params.flow) for w, _ in winds]
        elif self.frame % params.flow.every == 0:
            for flow in self.flows:
                flow.update(p.positions)
        k_a = self.k_a[p.layer]
        return sum(share * wind_flow.flow_abrasion(flow, p.positions, p.normals, on_surface, k_a, w.speed)
                   for flow, (w, share) in zip(self.flows, winds, strict=True))

    def _fluvial(self, on_surface: np.ndarray) -> tuple[np.ndarray, float]:
        """The fluvial rate F of every particle (002 Alg. 1, lines 11–14) and the largest
        discharge of a cell (m³/y)."""
        p, water = self.particles, self.params.fluvial
        receivers = water_receivers.water_receivers(p.positions, self.water_grid, self.seed, self.frame)
        flow = discharge.discharge(basins.route_depressions(receivers), water.precipitation, water.sources)
        rate = fluvial.fluvial_rate(p.positions, p.normals, on_surface, p.layer, self.k_t, self.tau_c, flow.q,
                                    self.water_grid, water)
        return rate, float(flow.q.max())

    def _stress(self) -> Relaxation:
        """Relax the MPM state: the first frame of a run settles (from the lithostatic guess, on
        ``mpm.coarse_levels`` coarse grids first)."""
        mpm = self.params.mpm
        first = self.last_relaxation is None and self.frame == 0
        if first and mpm.lithostatic:
            lithostatic_guess(self.particles, self.surface_grid, self.rock, self.spacing)
        if first:
            self.last_relaxation = mpm_settle.settle(self.solver, self.particles, mpm.coarse_levels,
                                                     mpm.settle_substeps)
        else:
            self.last_relaxation = self.solver.relax(self.particles, mpm.substeps)
        return self.last_relaxation

    def _deposit(self, removed: np.ndarray, particles: Particles, keep: np.ndarray) -> np.ndarray:
        """Replace the particles by those of ``particles`` at the indices ``keep`` plus the
        deposits of the rock particles ``removed``; returns where the deposits were placed (the
        rest were exported). Each array is gathered once, into room for the deposits (a frame's
        copy of every particle's state is its largest memory traffic)."""
        room = len(removed) if self.params.processes.deposition else 0
        placed = np.zeros((0, 3))
        if room == 0 and len(keep) == len(particles):
            self.particles = particles
            return placed
        arrays = {name: _gathered(array, keep, room) for name, array in particles.arrays().items()}
        if room:
            grid = deposition.offset_grid(self.deposition_grid, self.seed, self.frame)
            occupancy = grid.occupancy(arrays["positions"][:len(keep)])
            placed, _ = deposition.deposit(removed, occupancy, grid, self.params.deposition, self.seed,
                                           self.frame)
            # the offset grid overhangs the domain by up to a cell: what lands beyond it is exported
            placed = placed[self.deposition_grid.inside(self.deposition_grid.cells_of(placed))]
            new = Particles.new(placed, np.full(len(placed), self.layers.deposit_index),
                                viability=self.params.deposition.deposit_viability, deposit=True)
            for name, array in new.arrays().items():
                arrays[name][len(keep):len(keep) + len(placed)] = array
        self.particles = Particles.from_arrays({name: array[:len(keep) + len(placed)]
                                                for name, array in arrays.items()})
        return placed


def _gathered(array: np.ndarray, keep: np.ndarray, room: int) -> np.ndarray:
    """The rows ``keep`` of ``array`` followed by ``room`` unset rows."""
    out = np.empty((len(keep) + room, *array.shape[1:]), dtype=array.dtype)
    np.take(array, keep, axis=0, out=out[:len(keep)], mode="clip")
    return out
