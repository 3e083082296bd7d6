"""An ensemble of 8 members, each a 128² climate-run (20 steps of 1000 y back to 20 ka, thermal
and fluvial), on a local dask cluster of 2 workers, against the same 8 runs one after the other.

* ``ensemble/8 members 128², 2 workers``: ``unerode-cli ensemble`` from start to end (cluster
  start, members, summary rasters, members.csv).
* ``ensemble/serial 8 climate-runs 128²``: the 8 members' ``unerode-cli climate-run`` commands
  run one after another, as a shell loop would (each its own process, with every core for its
  numba threads).
* ``ensemble/engine overhead per member``: (ensemble wall time − Σ member run times ÷ workers)
  ÷ members, where a member's run time is the one its done marker records (emptying its
  folder, running its steps in the worker, writing its log): what the engine adds per member —
  cluster start-up, scheduling, the summary — on top of the members' own work.

Target (on 2 cores): the ensemble within 0.6 × the serial sum; the overhead ≤ 1 s a member.
The numba kernels are compiled (or loaded) once before timing.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from affine import Affine
from pyproj import CRS

from harness import Timed, benchmark, ratio
from unerode_cli.io.rasters import write_terrain
from unerode_cli.io.terrain import Terrain
from unerode_cli.synthetic import synthesize

FOLDER = Path(tempfile.mkdtemp(prefix="unerode-bench-ensemble-"))
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
MEMBERS, WORKERS, SIZE = 8, 2, 128
ENSEMBLE, SERIAL = "ensemble/8 members 128², 2 workers", "ensemble/serial 8 climate-runs 128²"
OVERHEAD = "ensemble/engine overhead per member"
CLIMATE_OPTIONS = ["--chronology", str(DATA / "lr04" / "LR04stack.txt"), "--to", "20", "--dt", "1000",
                   "--process", "thermal,fluvial", "--downstream-below", "100", "-qq"]
_MEASURED: dict[str, float] = {}


def _dem() -> Path:
    path = FOLDER / "dem.tif"
    if not path.exists():
        north_up = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
        write_terrain(Terrain(synthesize("mountain", (SIZE, SIZE), 1500.0, 7), 30.0, 30.0,
                              CRS.from_epsg(32632).to_wkt(), north_up), path)
    return path


def _spec() -> Path:
    """The members' pipeline: climate-run with CLIMATE_OPTIONS (without -qq), K sampled."""
    spec = FOLDER / "ensemble.yaml"
    pairs = zip(CLIMATE_OPTIONS[:-1:2], CLIMATE_OPTIONS[1:-1:2], strict=True)
    options = "".join(f"      {flag[2:]}: \"{value}\"\n" for flag, value in pairs)
    spec.write_text(f"version: 1\nsteps:\n  - name: past\n    run: climate-run\n"
                    f"    args: [{_dem()}, past.tif]\n    options:\n{options}"
                    "sweep:\n  past.K: {log-uniform: [1.0e-5, 4.0e-5]}\n")
    return spec


def _unerode(*args: object) -> None:
    subprocess.run([sys.executable, "-m", "unerode_cli", *map(str, args)], check=True)


def _warm_up() -> None:
    """Compile or load the kernels once, outside the timings."""
    _unerode("climate-run", _dem(), FOLDER / "warm.tif", *CLIMATE_OPTIONS, "--overwrite")


def _run_ensemble() -> float:
    """Run the ensemble; keep the engine's overhead per member; its wall time."""
    out = FOLDER / "out"
    start = time.perf_counter()
    _unerode("ensemble", _spec(), out, "--members", MEMBERS, "--workers", WORKERS, "--overwrite", "-qq")
    wall = time.perf_counter() - start
    runs = [json.loads((out / "members" / f"{i:04d}" / "done.json").read_text())["wall_s"]
            for i in range(MEMBERS)]
    _MEASURED[OVERHEAD] = (wall - sum(runs) / WORKERS) / MEMBERS
    _MEASURED[ENSEMBLE] = wall
    return wall


@benchmark(ENSEMBLE, whole_run=True)
def _ensemble_case():
    _warm_up()
    return (lambda: Timed(_run_ensemble())), MEMBERS, "members"


@benchmark(SERIAL, whole_run=True)
def _serial_case():
    _warm_up()
    if ENSEMBLE not in _MEASURED:
        _run_ensemble()
    values = [json.loads((FOLDER / "out" / "members" / f"{i:04d}" / "member.json").read_text())
              ["parameters"]["past.K"] for i in range(MEMBERS)]

    def work() -> None:
        for i, k in enumerate(values):
            _unerode("climate-run", _dem(), FOLDER / f"serial{i}.tif", *CLIMATE_OPTIONS, "--K", k,
                     "--overwrite")
    return work, MEMBERS, "members"


@benchmark(OVERHEAD, whole_run=True)
def _overhead_case():
    if OVERHEAD not in _MEASURED:
        _warm_up()
        _run_ensemble()
    return (lambda: Timed(_MEASURED[OVERHEAD])), 1, "members"


ratio("ensemble wall / serial sum, 8 members on 2 workers (target ≤ 0.6)", ENSEMBLE, SERIAL)
