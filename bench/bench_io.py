"""Start-up and raster I/O benchmarks."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from affine import Affine
from pyproj import CRS

from harness import benchmark
from unerode_cli.io.rasters import read_terrain, write_terrain
from unerode_cli.io.terrain import Terrain

SIZE = 4096
FOLDER = Path(tempfile.mkdtemp(prefix="unerode-bench-"))


@benchmark("cli/help wall time")
def cli_help():
    def work():
        subprocess.run([sys.executable, "-m", "unerode_cli", "--help"], check=True,
                       capture_output=True)
    return work, 1, "run"


def _terrain() -> Terrain:
    rng = np.random.default_rng(0)
    z = np.cumsum(rng.standard_normal((SIZE, SIZE)), axis=1).astype(np.float32).astype(np.float64)
    return Terrain(z, 30.0, 30.0, CRS.from_epsg(32632).to_wkt(),
                   Affine(30, 0, 500000, 0, -30, 5200000), None, {})


def _write_case(suffix: str):
    terrain = _terrain()
    path = FOLDER / f"w{suffix}"

    def work():
        path.unlink(missing_ok=True)
        write_terrain(terrain, path)
    return work, SIZE * SIZE * 4 / 1e6, "MB"


def _read_case(suffix: str):
    path = FOLDER / f"r{suffix}"
    path.unlink(missing_ok=True)
    write_terrain(_terrain(), path)
    return (lambda: read_terrain(path)), SIZE * SIZE * 4 / 1e6, "MB"


for _suffix, _name in ((".tif", "geotiff"), (".exr", "exr")):
    benchmark(f"io/write {_name} {SIZE}² float32")(lambda s=_suffix: _write_case(s))
    benchmark(f"io/read {_name} {SIZE}² float32")(lambda s=_suffix: _read_case(s))
