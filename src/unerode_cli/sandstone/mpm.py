"""The rock's internal stress by MLS-MPM with the corotated model (002 §4, Eq. 3–6).

The rock is at rest: what matters is the static stress, which MPM reaches by dynamic relaxation.
Each *substep* is one explicit MLS-MPM step (``mpm_kernels``) of Δt = cfl·h/c_p (c_p the speed
of compression waves), with grid velocities damped by a factor (1 − d) per step; a *relaxation*
runs substeps until the RMS node speed falls below ``tolerance``·gH/c_p (the speed scale of the
self-weight settling of a rock of height H) or a substep budget is spent. The first frame
settles from a lithostatic guess (each particle uniaxially loaded by the rock above it), first
on coarser grids (``mpm_settle``, ``MpmParams.coarse_levels``), every later frame starts from
the previous frame's state (warm start).

The criterion reads the node speeds after a substep; right after a kinetic-damping stop (all
velocities zero) that speed is one substep's acceleration, so the criterion then bounds the RMS
nodal force imbalance by tolerance·(H/(cfl·h))·g (0.5 g for a rock 74 cells high at the
defaults). A state that meets it at 2e-3 differs from one at 1e-4 by ~7 % of the largest stress
(``arch``, 60 000 particles: 6.5 % max, 7 % RMS; 1e-3: 3.3 %; 5e-4: 0.6 %).

Precision: with μ = 15 GPa the self-weight strain of a rock tens of metres high is ~1e-5, below
float32 resolution per substep; F, velocities and positions are float64, so the real stiffness
is kept (no stiffness scale). The static stress of a linear elastic body under gravity with
fixed displacement boundaries depends on Poisson's ratio only, which the tests check.

Damping (dynamic relaxation): kinetic damping (Cundall's: when the kinetic energy passes a peak,
every particle's velocity and affine velocity are set to zero) plus a light viscous damping, d
= ``KINETIC_VISCOUS_SHARE``·π·cfl·h/H by default, a quarter of the critical damping of the
lowest axial mode of a bar of height H fixed at its base (ω₁ = πc_p/2H, 2ω₁Δt = π·cfl·h/H).
Viscous damping alone is critical for one mode only and overdamps the slow ones (a heavy cap
on a pillar); with the kinetic damping a cap-loaded pillar settles 2.5 times faster, a free
column 1.5 times. Slender, bending structures still relax slowly; give them more substeps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from unerode_cli.sandstone import mpm_kernels as kernels
from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.layers import GRAVITY, Rock
from unerode_cli.sandstone.particles import Particles

#: Share of the critical damping of the lowest axial mode kept with kinetic damping.
KINETIC_VISCOUS_SHARE = 0.25
#: Below this many particles the substeps run on one thread: a substep has seven parallel
#: loops, each ending at a barrier, and on a busy machine (threads descheduled) the barriers of a
#: small substep cost more than the work they share. The result does not depend on it.
SERIAL_BELOW = 100_000


@dataclass(frozen=True)
class MpmParams:
    """Settings of the stress solver.

    Attributes: ``cfl`` time step as a share of h/c_p; ``substeps`` most substeps of a frame;
    ``settle_substeps`` most substeps of the first frame; ``tolerance`` convergence threshold on
    the RMS node speed in units of gH/c_p; ``damping`` viscous velocity damping per substep
    (None: ``KINETIC_VISCOUS_SHARE``·π·cfl·h/H, see the module docstring); ``kinetic`` whether
    kinetic damping runs too; ``lithostatic`` start the first frame from the
    lithostatic guess; ``coarse_levels`` coarse levels the first frame settles on before the
    fine one (``mpm_settle``; 0: a plain relaxation).
    """

    cfl: float = 0.3
    substeps: int = 10
    settle_substeps: int = 3000
    tolerance: float = 2e-3
    damping: float | None = None
    kinetic: bool = True
    lithostatic: bool = True
    coarse_levels: int = 2

    def __post_init__(self) -> None:
        if not 0.0 < self.cfl <= 0.5:
            raise ValueError(f"the MPM CFL number must be in (0, 0.5], got {self.cfl}")
        if self.substeps < 1 or self.settle_substeps < 1:
            raise ValueError("the MPM needs at least one substep per frame")
        if self.coarse_levels < 0:
            raise ValueError(f"the coarse levels must be 0 or more, got {self.coarse_levels}")


@dataclass(frozen=True)
class Relaxation:
    """What one relaxation did: substeps run, final residual (RMS node speed over gH/c_p)
    and whether it fell below the tolerance, all on the particles' own grid; for a multilevel
    settling (``mpm_settle``) also the substeps of each coarse level, finest first, and their
    cost in fine substeps (each weighted by its level's particles over the fine ones)."""

    substeps: int
    residual: float
    converged: bool
    coarse_substeps: tuple[int, ...] = ()
    coarse_cost: float = 0.0


class StressSolver:
    """MLS-MPM on ``grid`` for particles of volume ``particle_volume`` (m³) of ``rock``: one
    volume for all, or one per particle ``(N,)`` (the coarse levels of ``mpm_settle``)."""

    def __init__(self, grid: Grid3D, rock: Rock, particle_volume: float | np.ndarray,
                 params: MpmParams = MpmParams()):
        self.grid, self.rock, self.params = grid, rock, params
        self.volume = particle_volume
        self.mass = rock.density * particle_volume
        self._volumes = np.ascontiguousarray(np.atleast_1d(particle_volume), dtype=np.float64)
        self._masses = rock.density * self._volumes
        self.dt = params.cfl * grid.h / rock.p_wave_speed
        self.origin = np.asarray(grid.origin, dtype=np.float64)
        self.upper = self.origin + np.asarray(grid.shape) * grid.h * (1.0 - 1e-12)
        self.nodes = tuple(n + 3 for n in grid.shape)
        #: momentum (then velocity) and mass of each node, zero outside ``bounds`` between substeps
        self.nodal = np.zeros((*self.nodes, 4))
        #: the box of nodes the particles reach (``mpm_kernels.node_bounds``); None: not known
        self.bounds: np.ndarray | None = None
        #: when set (``(nx, ny, nz, 4)``), each substep adds its node displacements (m) to it
        self.displacement: np.ndarray | None = None
        self.blocks = (self.nodes[0] // kernels.BLOCK + 1, self.nodes[1] // kernels.BLOCK + 1)
        self.colour_blocks, self.colour_starts = _colours(*self.blocks)

    def relax(self, particles: Particles, max_substeps: int) -> Relaxation:
        """Run substeps on the particles' MPM state (in place) until it is static or
        ``max_substeps`` are done; then set each particle's ``stress`` (−tr σ, Pa)."""
        if len(particles) == 0:
            return Relaxation(0, 0.0, True)
        threads = numba.get_num_threads()
        if len(particles) < SERIAL_BELOW:
            numba.set_num_threads(1)
        try:
            return self._relax(particles, max_substeps)
        finally:
            numba.set_num_threads(threads)

    def _relax(self, particles: Particles, max_substeps: int) -> Relaxation:
        height = max(self.grid.h, float(particles.positions[:, 2].max()) - self.origin[2])
        damping = self.params.damping
        if damping is None:
            damping = min(0.5, KINETIC_VISCOUS_SHARE * math.pi * self.params.cfl * self.grid.h / height)
        speed_scale = GRAVITY * height / self.rock.p_wave_speed
        self.bounds = None
        order = starts = None
        drift = math.inf
        residual = math.inf
        previous = 0.0
        done = 0
        while done < max_substeps:
            if drift > 0.5 * self.grid.h:
                order, starts = self._sorted(particles.positions)
                drift = 0.0
            fastest = self.substep(particles, order, starts, damping)
            drift += fastest * self.dt
            if self.params.kinetic and fastest < previous:
                particles.velocity[:] = 0.0
                particles.affine[:] = 0.0
                previous = 0.0
            else:
                previous = fastest
            done += 1
            residual = fastest / speed_scale
            if residual < self.params.tolerance:
                break
        particles.stress = self.smoothed(particles, kernels.compressive_stress(
            particles.deformation, self.rock.shear_modulus, self.rock.lame_lambda)[:, None])[:, 0]
        return Relaxation(done, residual, residual < self.params.tolerance)

    def substep(self, particles: Particles, order: np.ndarray, starts: np.ndarray, damping: float) -> float:
        """One MLS-MPM step; returns the mass-weighted RMS grid speed (m/s). ``order`` and
        ``starts`` come from :meth:`_sorted` on positions at most ``BLOCK − 2`` nodes from the
        current ones; ``self.bounds`` holds the particles' box of nodes (None: found here)."""
        if self.bounds is None:
            self.bounds = kernels.node_bounds(particles.positions, self.origin, self.grid.h)
        bounds = self.bounds
        kernels.particles_to_grid(order, starts, self.colour_blocks, self.colour_starts, particles.positions,
                                  particles.velocity, particles.affine, particles.deformation, self._masses,
                                  self._volumes, self.rock.shear_modulus, self.rock.lame_lambda, self.dt,
                                  self.origin, self.grid.h, self.nodal)
        fastest = kernels.update_grid(self.nodal, bounds, self.dt, GRAVITY, damping)
        if self.displacement is not None:
            kernels.accumulate(self.nodal, bounds, self.dt, self.displacement)
        self.bounds = kernels.grid_to_particles(self.nodal, particles.positions, particles.velocity,
                                                particles.affine, particles.deformation, self.dt, self.origin,
                                                self.grid.h, self.upper)
        kernels.clear(self.nodal, bounds)
        return float(fastest)

    def _sorted(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        keys = kernels.block_keys(positions, self.origin, self.grid.h, self.blocks[1])
        return kernels.counting_sort(keys, self.blocks[0] * self.blocks[1])

    def cauchy_stress(self, particles: Particles) -> np.ndarray:
        """Smoothed σ (Pa, tension positive) of every particle, ``(N, 3, 3)``."""
        sigma = kernels.cauchy_stress(particles.deformation, self.rock.shear_modulus, self.rock.lame_lambda)
        return self.smoothed(particles, sigma.reshape(-1, 9)).reshape(-1, 3, 3)

    def smoothed(self, particles: Particles, values: np.ndarray) -> np.ndarray:
        """A per-particle field ``(N, m)`` smoothed through the grid (particle → node averages →
        particle, with the B-spline weights).

        At rest, MPM balances forces at the nodes only: eight particles share a cell and their
        stresses may differ by patterns that exert no nodal force, a noise of ~10 % on a column
        under its own weight. The stress the grid carries, and that Eq. 2 should see, is the
        smoothed one (within ~1 % on the same column)."""
        order, starts = self._sorted(particles.positions)
        weight = np.zeros(self.nodes)
        sums = np.zeros((*self.nodes, values.shape[1]))
        kernels.scatter_values(order, starts, self.colour_blocks, self.colour_starts, particles.positions,
                               np.ascontiguousarray(values, dtype=np.float64), self.origin, self.grid.h,
                               weight, sums)
        return kernels.gather_values(weight, sums, particles.positions, self.origin, self.grid.h)


def _colours(blocks_x: int, blocks_y: int) -> tuple[np.ndarray, np.ndarray]:
    """Block ids grouped by colour (parity of the block's x and y index) and the start of each
    colour's group."""
    bx, by = np.meshgrid(np.arange(blocks_x), np.arange(blocks_y), indexing="ij")
    ids = (bx * blocks_y + by).ravel()
    colour = ((bx % 2) * 2 + (by % 2)).ravel()
    order = np.argsort(colour, kind="stable")
    starts = np.searchsorted(colour[order], np.arange(5)).astype(np.int64)
    return ids[order].astype(np.int64), starts


def lithostatic_guess(particles: Particles, grid: Grid3D, rock: Rock, spacing: float) -> None:
    """Set F (in place) to the geostatic strain of the weight above each particle: the rock
    lies bonded to its ground, so it is strained in uniaxial strain (Jaeger, Cook & Zimmerman
    2007, ch. 5): in each column of ``grid`` (the surface grid, one particle per cell), a particle
    under n others carries σ_zz = −ρ g (n + ½) s, so ε_zz = σ_zz/(λ + 2μ), ε_xx = ε_yy = 0 and
    σ_xx = σ_yy = ν/(1 − ν)·σ_zz.

    MPM integrates F from the velocities and never checks it against the held ground, so the
    start decides which static state a wide body settles in: from a state of uniaxial stress
    (ε_xx = −ν ε_zz, σ_xx = 0, in equilibrium everywhere) the interior of a wide layer keeps σ_xx
    = 0 as if it slid on its base. Near free faces the relaxation removes the lateral stress the
    guess puts there (a free column ends with σ_xx ≈ 0 either way, ``test_mpm``)."""
    cells = grid.cells_of(particles.positions)
    column = cells[:, 0] * grid.shape[1] + cells[:, 1]
    order = np.lexsort((-particles.positions[:, 2], column))
    sorted_columns = column[order]
    first = np.searchsorted(sorted_columns, sorted_columns, side="left")
    above = np.empty(len(order))
    above[order] = np.arange(len(order)) - first
    sigma_zz = -rock.density * GRAVITY * (above + 0.5) * spacing
    deformation = np.zeros((len(order), 3, 3))
    deformation[:, 0, 0] = deformation[:, 1, 1] = 1.0
    deformation[:, 2, 2] = 1.0 + sigma_zz / (rock.lame_lambda + 2.0 * rock.shear_modulus)
    particles.deformation = deformation
