"""Sandstone (002) benchmarks: the MLS-MPM stress solver at 002 §8.3's scale (1 M particles, 128³
grid) as a run pays it, against a plain single-thread MLS-MPM sketch (``mpm_reference``) on the
same particles; a first frame and a later frame at 1 M particles; the README example (the
``arch`` preset at 50 000 particles, 100 frames, through the command line, start-up included),
the surface and transport stages of ``sandstone_stages`` (about 0.9 M particles, 2 threads), and
002 §8.3's "3D flow routing (fluvial erosion + deposition)" on the block: water receivers,
depression routing, discharge, the fluvial rate and the deposition of 2000 eroded particles.

The block: 128 × 128 × 61 particles of spacing 0.5 m (1 M, 8 per MPM cell of 1 m) standing in
a 128 m cubic domain, the MPM grid 128³. A *substep as a run pays it* is a later frame's stress
relaxation (``StressSolver.relax`` with the default ``MpmParams``, as ``Simulation`` calls it:
sorting, the substeps, and the smoothed stress) divided by the substeps it ran, on the settled
block, with no early stop (a frame's 10 substeps: an early stop after one substep would charge
it the whole frame's sorting and smoothing); the case prints the final residual. The sketch
runs its substep on the same (lithostatic) state on one thread. The first frame is
``Simulation.step`` from the sampled block (lithostatic guess, then the multilevel settling,
``mpm_settle``, up to ``settle_substeps`` a level), timed once, printing the fine and coarse
substeps; the later frame is a whole ``Simulation.step`` after it
(default parameters). The cases print the substeps and residuals they ran.
"""

from __future__ import annotations

import functools
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from harness import Timed, benchmark, ratio
from mpm_reference import Reference
from sandstone_stages import (
    deflation_case,
    deposition_case,
    fluvial_case,
    normals_case,
    support_case,
    surface_case,
    wind_case,
)
from unerode_cli.sandstone.layers import GRAVITY, Layer, LayerStack, Rock
from unerode_cli.sandstone.mpm import MpmParams, StressSolver, lithostatic_guess
from unerode_cli.sandstone.particles import Particles
from unerode_cli.sandstone.sampling import Lattice, sample
from unerode_cli.sandstone.scene import Box
from unerode_cli.sandstone.simulation import Simulation, SimulationParams

SPACING = 0.5
DOMAIN = (128.0, 128.0, 128.0)
BLOCK = Box(min=(32.0, 32.0, 0.0), max=(96.0, 96.0, 30.5))


def _threads(count: int) -> None:
    numba.set_num_threads(min(count, numba.config.NUMBA_NUM_THREADS))


def _block() -> tuple[Particles, Lattice]:
    lattice = Lattice((0.0, 0.0, 0.0), DOMAIN, SPACING)
    positions = sample(BLOCK, lattice, seed=0)
    return Particles.new(positions, np.zeros(len(positions))), lattice


@functools.cache
def _settled_solver() -> tuple[StressSolver, Particles]:
    """The block after its first frame's relaxation (2 threads): the state later frames start from
    (shared by the substep cases)."""
    particles, lattice = _block()
    solver = StressSolver(lattice.mpm_grid(), Rock(), SPACING**3, MpmParams())
    lithostatic_guess(particles, lattice.surface_grid(), Rock(), SPACING)
    _threads(2)
    solver.relax(particles, MpmParams().settle_substeps)
    solver.params = MpmParams(tolerance=0.0)
    return solver, particles


def _substep(threads: int):
    solver, particles = _settled_solver()

    def work() -> Timed:
        _threads(threads)
        start = time.perf_counter()
        relaxation = solver.relax(particles, MpmParams().substeps)
        seconds = time.perf_counter() - start
        print(f"    {threads} thread(s): {relaxation.substeps} substeps, residual {relaxation.residual:.3g}")
        return Timed(seconds / max(relaxation.substeps, 1))

    return work, len(particles), "particles"


def _reference():
    particles, lattice = _block()
    grid, rock = lattice.mpm_grid(), Rock()
    lithostatic_guess(particles, lattice.surface_grid(), rock, SPACING)
    solver = StressSolver(grid, rock, SPACING**3)
    sketch = Reference(particles.positions, particles.deformation, grid.shape, grid.h, solver.origin,
                       solver.mass, solver.volume, rock.shear_modulus, rock.lame_lambda, solver.dt)

    def work() -> None:
        _threads(1)
        sketch.substep(GRAVITY, 0.01)

    return work, len(particles), "particles"


def _simulation() -> Simulation:
    particles, lattice = _block()
    return Simulation(particles, LayerStack((Layer(),)), Rock(), lattice, SimulationParams())


def _first_frame():
    def work() -> Timed:
        simulation = _simulation()
        _threads(2)
        start = time.perf_counter()
        stats = simulation.step()
        seconds = time.perf_counter() - start
        coarse = simulation.last_relaxation.coarse_substeps if simulation.last_relaxation else ()
        print(f"    first frame: {stats.mpm_substeps} fine substeps, residual {stats.mpm_residual:.3g}, "
              f"coarse substeps {coarse} (= {stats.mpm_coarse_cost:.1f} fine), stages "
              + ", ".join(f"{k} {v:.2f} s" for k, v in stats.seconds.items()))
        return Timed(seconds)

    return work, 1, "frames"


def _frame():
    simulation = _simulation()
    _threads(2)
    simulation.step()

    def work() -> None:
        _threads(2)
        stats = simulation.step()
        print(f"    frame: {stats.mpm_substeps} substeps, residual {stats.mpm_residual:.3g}")

    return work, len(simulation.particles), "particles"


def _readme():
    def work() -> Timed:
        out = Path(tempfile.mkdtemp()) / "arch"
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "unerode_cli", "sandstone", "arch", str(out), "--particles",
                        "50000", "--frames", "100", "-q"], check=True)
        seconds = time.perf_counter() - start
        shutil.rmtree(out.parent)
        return Timed(seconds)

    return work, 100, "frames"


SUBSTEP_1 = "sandstone/mpm substep as a frame pays it 1M particles 128³ 1 thread"
SUBSTEP_2 = "sandstone/mpm substep as a frame pays it 1M particles 128³ 2 threads"
SKETCH = "sandstone/mpm reference sketch substep 1M particles 128³ 1 thread"
benchmark(SUBSTEP_1)(lambda: _substep(1))
benchmark(SUBSTEP_2)(lambda: _substep(2))
benchmark(SKETCH)(_reference)
ratio("sandstone mpm substep 2 threads / reference sketch 1 thread", SUBSTEP_2, SKETCH)
ratio("sandstone mpm substep 1 thread / 2 threads (speed-up)", SUBSTEP_1, SUBSTEP_2)
benchmark("sandstone/first frame 1M particles 128³ 2 threads", whole_run=True)(_first_frame)
benchmark("sandstone/frame 1M particles 128³ 2 threads")(_frame)
benchmark("sandstone/readme arch 50k particles 100 frames", whole_run=True)(_readme)
benchmark("sandstone/stage surface particles 0.9M particles 2 threads")(surface_case)
benchmark("sandstone/stage normals all 0.9M particles 2 threads")(normals_case)
benchmark("sandstone/stage normals near changes 0.9M particles 2 threads")(
    lambda: normals_case(incremental=True))
benchmark("sandstone/stage wind abrasion 0.9M particles 2 threads")(wind_case)
benchmark("sandstone/stage deflation 0.9M particles 2 threads")(deflation_case)
benchmark("sandstone/stage deposition 2000 eroded 2 threads")(deposition_case)
benchmark("sandstone/stage block-fall test 0.9M particles 2 threads")(support_case)
benchmark("sandstone/stage water routing discharge fluvial deposition 1M particles 128³ 2 threads")(
    lambda: fluvial_case(*_block()))
