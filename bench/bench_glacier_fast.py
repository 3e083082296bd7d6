"""Coupled glacier runs (issue #20, "Fast"): whole runs of ``glacier.coupled``, per step.

- the bench ice cap of ``bench_glacier`` (256² and 512², N = 10, dt = 10 y) over STEPS[n] steps
  from its solved start: the mean cost of a coupled step (mass balance, Blatter–Pattyn velocities
  to the re-solve policy of ``coupled``, multi-scale transport, erosion) as the cap melts back;
- Grindelwald (../shared/data, 333 × 344 cells of 46 m), ELA 2900 m, dt = 20 y, 1000 years from
  no ice: the time of the whole run (``unerode-cli glaciate DEM OUT --ela 2900 --dt 20
  --duration 1000`` without its I/O);
- a glacial cycle after 001 Fig. 6 on a 256² crop of Grindelwald: the ELA falls from 4000 m
  (above the peaks) by 1800 m over 100 ky, then rises 500 m over 20 ky, dt = 50 y. The whole
  cycle (2400 steps) is too long to repeat here: the case times CYCLE_STEPS steps from t = 60 ky
  (the state there is computed once, in the set-up), where the ice is near its largest, so the
  figure, times 2400, bounds the whole cycle from above.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import bench_glacier as ice_cap  # noqa: I001 (a sibling bench module: bench/ is on sys.path)
from harness import Timed, benchmark
from unerode_cli.glacier import coupled
from unerode_cli.grid import Grid

STEPS = {256: 100, 512: 20}
GRINDELWALD = (Path(__file__).resolve().parents[2] / "shared" / "data" / "dem" / "alps_grindelwald"
               / "dem.tif")
CYCLE_DT = 50.0
CYCLE_STEPS = 40
CYCLE_START = 60_000.0


def _cap_run(n: int):
    start = ice_cap._ice_cap(n)
    steps = STEPS[n]

    def work():
        state, grid, params = start
        t0 = time.perf_counter()
        for _ in range(steps):
            state = coupled.step(state, grid, params, ice_cap.COUPLED_ELA, 10.0)[0]
        return Timed(time.perf_counter() - t0)

    return work, steps, "steps"


for _n in STEPS:
    benchmark(f"glacier/coupled run {_n}²×{ice_cap.N_LAYERS} ice cap, {STEPS[_n]} steps of 10 y",
              whole_run=True)(lambda n=_n: _cap_run(n))


def _grindelwald() -> tuple[np.ndarray, Grid]:
    from unerode_cli.io.rasters import read_terrain

    terrain = read_terrain(GRINDELWALD)
    return coupled.fill_outside(terrain.elevation, terrain.grid.valid), terrain.grid


@benchmark("glacier/Grindelwald 344×333 ELA 2900 m, 1000 y at dt 20 y", whole_run=True)
def _grindelwald_run():
    bed, grid = _grindelwald()
    params = coupled.CoupledParams()
    times = coupled.step_times(1000.0, 20.0)

    def work():
        return coupled.run(coupled.GlacierState(bed, np.zeros_like(bed)), grid, params, 2900.0, times)

    return work, 1000.0, "years"


def cycle_ela() -> coupled.ElaTable:
    """001 Fig. 6 scaled: 4000 m → 2200 m over 100 ky → 2700 m at 120 ky (m, times in y)."""
    return coupled.ElaTable(np.array([0.0, 100_000.0, 120_000.0]), np.array([4000.0, 2200.0, 2700.0]))


def cycle_start():
    """A 256² crop of Grindelwald, its grid and the default parameters."""
    bed, grid = _grindelwald()
    bed = np.ascontiguousarray(bed[40:296, 44:300])
    return bed, Grid.full(bed.shape, grid.dx, grid.dy), coupled.CoupledParams()


@benchmark(f"glacier/cycle 001 Fig. 6 on 256² Grindelwald, {CYCLE_STEPS} steps of {CYCLE_DT:g} y from 60 ky",
           whole_run=True)
def _cycle_part():
    bed, grid, params = cycle_start()
    ela = cycle_ela()
    start = coupled.run(coupled.GlacierState(bed, np.zeros_like(bed)), grid, params, ela,
                        coupled.step_times(CYCLE_START, CYCLE_DT)).state
    times = start.time + CYCLE_DT * np.arange(1, CYCLE_STEPS + 1)

    def work():
        return coupled.run(start, grid, params, ela, times)

    return work, CYCLE_STEPS, "steps"
