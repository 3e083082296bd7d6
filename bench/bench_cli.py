"""Whole commands through the command line: ``erode`` on a 512² DEM with 1 and with 21 steps.

The per-step cost of the command is (t21 − t1) / 20, to compare with ``fluvial/forward step
512²`` (the kernel step with routing); start-up, reading and writing cancel out."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

from affine import Affine

from harness import benchmark
from unerode_cli.io.rasters import write_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.synthetic import synthesize

FOLDER = Path(tempfile.mkdtemp(prefix="unerode-bench-cli-"))


def _dem(n: int) -> Path:
    path = FOLDER / f"dem{n}.tif"
    if not path.exists():
        north_up = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
        relief = synthesize("mountain", (n, n), 1500.0, 2)
        write_terrain(Terrain(relief, 30.0, 30.0, transform=north_up), path)
    return path


def _erode_case(n: int, steps: int):
    dem, out = _dem(n), FOLDER / f"out{n}_{steps}.tif"
    argv = [sys.executable, "-m", "unerode_cli", "erode", str(dem), str(out), "--steps", str(steps),
            "--dt", "100", "--overwrite", "-qq"]
    return (lambda: subprocess.run(argv, check=True)), steps, "steps"


for _steps in (1, 21):
    benchmark(f"cli/erode 512², {_steps} step(s), whole command")(lambda s=_steps: _erode_case(512, s))
