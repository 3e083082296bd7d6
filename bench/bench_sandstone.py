"""Sandstone (002) benchmarks: one MLS-MPM substep and one whole frame at 002 §8.3's scale (1 M
particles, 128³ grid) on 2 threads, a substep on 1 thread, the README example (the ``arch``
preset at 50 000 particles, 100 frames, through the command line, start-up included), the
surface and transport stages of ``sandstone_stages`` (about 0.9 M particles, 2 threads), and
002 §8.3's "3D flow routing (fluvial erosion + deposition)" on the block: water receivers,
depression routing, discharge, the fluvial rate and the deposition of 2000 eroded particles.

The block: 128 × 128 × 61 particles of spacing 0.5 m (1 M, 8 per MPM cell of 1 m) standing in
a 128 m cubic domain, the MPM grid 128³. The frame runs 10 substeps (no early stop), the
normals, the wind and the deposition; it is timed after a first frame (the settling).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

from harness import Timed, benchmark
from sandstone_stages import (
    deflation_case,
    deposition_case,
    fluvial_case,
    normals_case,
    surface_case,
    wind_case,
)
from unerode_cli.sandstone.layers import Layer, LayerStack, Rock
from unerode_cli.sandstone.mpm import MpmParams, StressSolver
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


def _substep(threads: int):
    particles, lattice = _block()
    solver = StressSolver(lattice.mpm_grid(), Rock(), SPACING**3)
    order, starts = solver._sorted(particles.positions)

    def work() -> float:
        _threads(threads)
        return solver.substep(particles, order, starts, 0.01)

    return work, len(particles), "particles"


def _frame():
    particles, lattice = _block()
    params = SimulationParams(mpm=MpmParams(substeps=10, settle_substeps=10, tolerance=0.0))
    simulation = Simulation(particles, LayerStack((Layer(),)), Rock(), lattice, params)
    _threads(2)
    simulation.step()

    def work() -> None:
        _threads(2)
        simulation.step()

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


benchmark("sandstone/mpm substep 1M particles 128³ 1 thread")(lambda: _substep(1))
benchmark("sandstone/mpm substep 1M particles 128³ 2 threads")(lambda: _substep(2))
benchmark("sandstone/frame 1M particles 128³ 10 substeps 2 threads")(_frame)
benchmark("sandstone/readme arch 50k particles 100 frames", whole_run=True)(_readme)
benchmark("sandstone/stage surface particles 0.9M particles 2 threads")(surface_case)
benchmark("sandstone/stage normals all 0.9M particles 2 threads")(normals_case)
benchmark("sandstone/stage normals near changes 0.9M particles 2 threads")(
    lambda: normals_case(incremental=True))
benchmark("sandstone/stage wind abrasion 0.9M particles 2 threads")(wind_case)
benchmark("sandstone/stage deflation 0.9M particles 2 threads")(deflation_case)
benchmark("sandstone/stage deposition 2000 eroded 2 threads")(deposition_case)
benchmark("sandstone/stage water routing discharge fluvial deposition 1M particles 128³ 2 threads")(
    lambda: fluvial_case(*_block()))
