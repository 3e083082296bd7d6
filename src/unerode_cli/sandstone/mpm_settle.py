"""The first frame's settling by multilevel dynamic relaxation (nested iteration, the first leg
of full multigrid; Brandt 1977): the rock settles first as coarse particles on a grid of 2h (and
4h, 8h, ... with more levels), whose substeps cost about a sixteenth of the fine ones and whose
waves cross the rock in half the substeps; the fine particles then follow the coarse grid's
displacements, and the fine relaxation runs until the same criterion as a plain one (``mpm``'s
module docstring: RMS node speed below ``tolerance``·gH/c_p on the fine grid). The stress is
the fine relaxation's; the coarse levels only choose where it starts.

Coarsening: the particles of each cell of a level's grid (about eight: the sampling puts one per
lattice cell, eight per MPM cell) become one coarse particle at their volume-weighted centroid
carrying their volume (and mass) and their volume-weighted mean deformation gradient F; the
next grid has cells twice as wide, so a coarse level holds about eight particles per cell again.

Prolongation: a coarse relaxation adds up the displacement u = Σ v Δt of its nodes, and every
finer level's particles follow it as tracers would have: x ← x + u(x), F ← (I + ∇u(x)) F, with
u and ∇u read from the coarse nodes by the same B-spline weights and MLS gradient as a substep's
grid-to-particle transfer (first order in ∇u, which is ~1e-5). Each particle keeps its own start
(the lithostatic guess), so the result is what the coarse dynamics do to the fine particles.

Measured (``arch``, 1 M particles, 2 levels): the fine level needs about half the substeps of a
plain relaxation, not fewer: the fine grid's static state differs from the coarse one's in
patterns the coarse grid cannot carry (the basal layer where the B-spline stencils meet the held
ground, and the stress patterns that fit the sampling's jitter, each an imbalance of several g
at the fine nodes), and relaxing them excites the rock's slow modes again.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from unerode_cli.sandstone import mpm_kernels as kernels
from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.mpm import Relaxation, StressSolver
from unerode_cli.sandstone.particles import Particles


def coarsened(particles: Particles, volumes: np.ndarray, grid: Grid3D) -> tuple[Particles, np.ndarray]:
    """One coarse particle per occupied cell of ``grid`` (cells in lexicographic order): at the
    volume-weighted centroid of the cell's particles, with their summed volume (m³) and their
    volume-weighted mean F, at rest. Returns the coarse particles and their volumes ``(M,)``."""
    cells = np.clip(grid.cells_of(particles.positions), 0, np.asarray(grid.shape) - 1)
    keys = (cells[:, 0] * grid.shape[1] + cells[:, 1]) * grid.shape[2] + cells[:, 2]
    unique, owner = np.unique(keys, return_inverse=True)
    total = np.bincount(owner, weights=volumes, minlength=len(unique))

    def mean(values: np.ndarray) -> np.ndarray:
        return np.stack([np.bincount(owner, weights=volumes * values[:, a], minlength=len(unique))
                         for a in range(values.shape[1])], axis=1) / total[:, None]

    coarse = Particles.new(mean(particles.positions), np.zeros(len(unique), dtype=np.int32))
    coarse.deformation = np.ascontiguousarray(mean(particles.deformation.reshape(-1, 9)).reshape(-1, 3, 3))
    return coarse, total


def coarser_grid(grid: Grid3D) -> Grid3D:
    """The grid of cells twice as wide from the same origin, covering ``grid``."""
    return Grid3D(grid.origin, 2.0 * grid.h, tuple((n + 1) // 2 for n in grid.shape))  # type: ignore[arg-type]


def settle(solver: StressSolver, particles: Particles, levels: int, max_substeps: int) -> Relaxation:
    """Relax ``particles`` (in place, from their F, e.g. ``lithostatic_guess``'s) with ``solver``
    after ``levels`` coarse levels (0: a plain relaxation), each level up to ``max_substeps``.
    The result is the fine relaxation's, with each coarse level's substeps (finest first) and
    their cost in fine substeps (substeps × the level's particles / the fine particles)."""
    volumes = np.ascontiguousarray(np.broadcast_to(np.asarray(solver.volume, dtype=np.float64),
                                                   (len(particles),)))
    chain: list[tuple[StressSolver, Particles]] = [(solver, particles)]
    grid, current = solver.grid, particles
    for _ in range(levels):
        if len(current) == 0:
            break
        current, volumes = coarsened(current, volumes, grid)
        grid = coarser_grid(grid)
        chain.append((StressSolver(grid, solver.rock, volumes, solver.params), current))
    coarse: list[Relaxation] = []
    for level in range(len(chain) - 1, 0, -1):
        level_solver, level_particles = chain[level]
        level_solver.displacement = np.zeros((*level_solver.nodes, 4))
        coarse.append(level_solver.relax(level_particles, max_substeps))
        for finer_solver, finer in chain[:level]:
            follow(level_solver, finer_solver, finer)
    fine = solver.relax(particles, max_substeps)
    substeps = tuple(r.substeps for r in reversed(coarse))
    cost = sum(n * len(p) for n, (_, p) in zip(substeps, chain[1:], strict=True)) / max(len(particles), 1)
    return replace(fine, coarse_substeps=substeps, coarse_cost=float(cost))


def follow(coarse: StressSolver, solver: StressSolver, particles: Particles) -> None:
    """Move ``particles`` (those of ``solver``) with the displacements the ``coarse`` solver added
    up (``StressSolver.displacement``): x ← x + u(x) (kept in ``solver``'s domain), F ← (I + ∇u(x))
    F; they are at rest afterwards."""
    kernels.grid_to_particles(coarse.displacement, particles.positions, particles.velocity, particles.affine,
                              particles.deformation, 1.0, coarse.origin, coarse.grid.h, solver.upper)
    particles.velocity[:] = 0.0
    particles.affine[:] = 0.0
