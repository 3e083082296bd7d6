"""Whole commands through the command line: ``erode`` on a 512² DEM with 1 and with 21 steps.

The per-step cost of the command is (t21 − t1) / 20: start-up, reading and writing cancel out.
``cli/erode 512², per step`` times the two commands back to back and keeps the median of
those differences, which is steadier than the difference of two medians (the start-up alone
varies by ±0.1 s on a busy machine, i.e. ±5 ms a step).

It is compared with ``cli/kernels 512², per step``: the same 20 steps (steps 2–21 from the
same DEM, hence the same elevations) done by ``fluvial.step`` with the flow routing
(priority-flood + order) computed inside, as ``fluvial/forward step 512²`` does, plus
``h += dh``. That is the kernel step on this DEM; ``fluvial/forward step 512²`` runs on a
tilted random surface whose routing and sweep are cheaper (about 20 ms against 27 ms), so the
ratio to it mixes the terrain into the command's overhead.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from affine import Affine

from harness import Timed, benchmark, ratio
from unerode_cli.hydro import outlet_mask
from unerode_cli.io.rasters import read_terrain, write_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.processes import fluvial
from unerode_cli.synthetic import synthesize

FOLDER = Path(tempfile.mkdtemp(prefix="unerode-bench-cli-"))
DT = 100.0
STEPS = 21


def _dem(n: int) -> Path:
    path = FOLDER / f"dem{n}.tif"
    if not path.exists():
        north_up = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
        relief = synthesize("mountain", (n, n), 1500.0, 2)
        write_terrain(Terrain(relief, 30.0, 30.0, transform=north_up), path)
    return path


def _erode_argv(n: int, steps: int) -> list[str]:
    dem, out = _dem(n), FOLDER / f"out{n}_{steps}.tif"
    return [sys.executable, "-m", "unerode_cli", "erode", str(dem), str(out), "--steps", str(steps),
            "--dt", str(DT), "--overwrite", "-qq"]


def _erode_case(n: int, steps: int):
    argv = _erode_argv(n, steps)
    return (lambda: subprocess.run(argv, check=True)), steps, "steps"


def _erode_per_step_case(n: int, steps: int):
    """(t(steps) − t(1)) / (steps − 1) of the command, both timed back to back."""
    one, many = _erode_argv(n, 1), _erode_argv(n, steps)

    def work() -> Timed:
        start = time.perf_counter()
        subprocess.run(one, check=True)
        middle = time.perf_counter()
        subprocess.run(many, check=True)
        return Timed(((time.perf_counter() - middle) - (middle - start)) / (steps - 1))
    return work, 1, "steps"


def _kernel_per_step_case(n: int, steps: int):
    """Steps 2..``steps`` of the command's run done by the kernels alone, per step."""
    terrain = read_terrain(_dem(n))
    grid, params = terrain.grid, fluvial.FluvialParams()  # the command's defaults
    outlets = outlet_mask(grid, "all")
    first = np.array(terrain.elevation, dtype=np.float64)
    first += fluvial.step(first, grid, outlets, params, DT).dh

    def work() -> Timed:
        h = first.copy()
        start = time.perf_counter()
        for _ in range(steps - 1):
            h += fluvial.step(h, grid, outlets, params, DT).dh
        return Timed((time.perf_counter() - start) / (steps - 1))
    return work, 1, "steps"


for _steps in (1, STEPS):
    benchmark(f"cli/erode 512², {_steps} step(s), whole command")(lambda s=_steps: _erode_case(512, s))
CLI_STEP = f"cli/erode 512², per step ((t{STEPS} − t1) / {STEPS - 1}, back to back)"
KERNEL_STEP = f"cli/kernels 512², per step (fluvial.step with routing, steps 2–{STEPS}, same DEM)"
benchmark(CLI_STEP)(lambda: _erode_per_step_case(512, STEPS))
benchmark(KERNEL_STEP)(lambda: _kernel_per_step_case(512, STEPS))
ratio("cli step / kernel step, same DEM and steps (target ≤ 1.3)", CLI_STEP, KERNEL_STEP)
ratio("cli step / fluvial/forward step 512² (tilted random surface)", CLI_STEP,
      "fluvial/forward step 512²")
