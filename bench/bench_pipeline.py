"""What a pipeline adds per step: a spec of 8 `erode` steps of one 10-year step each on a 64²
DEM (the erosion itself takes milliseconds), run by ``unerode-cli pipeline run``.

* ``pipeline/8 tiny erode steps``: the whole ``pipeline run`` (one process start, the spec
  checked, 8 steps); its wall time ÷ 8 is what a step costs beyond its own computation.

Run as a script (``python bench/bench_pipeline.py``) it prints the wall time per step, so the
same spec can be timed with another checkout on ``PYTHONPATH``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

STEPS, SIZE = 8, 64
NAME = "pipeline/8 tiny erode steps 64²"


def _spec(folder: Path) -> Path:
    import rasterio
    from affine import Affine

    dem = folder / "dem.tif"
    rng = np.random.default_rng(3)
    data = (1000.0 + 50.0 * rng.random((SIZE, SIZE)) + np.arange(SIZE)[:, None] * 2.0).astype(np.float32)
    with rasterio.open(dem, "w", driver="GTiff", height=SIZE, width=SIZE, count=1, dtype="float32",
                       crs="EPSG:32632", transform=Affine(30.0, 0, 500000.0, 0, -30.0, 5000000.0)) as dst:
        dst.write(data, 1)
    lines = ["version: 1", "steps:"]
    previous = str(dem)
    for i in range(STEPS):
        lines += [f"  - name: s{i}", "    run: erode", f"    args: [\"{previous}\", s{i}.tif]",
                  "    options: {dt: 10, steps: 1}"]
        previous = f"${{steps.s{i}.output}}"
    spec = folder / "spec.yaml"
    spec.write_text("\n".join(lines) + "\n")
    return spec


def run_once(folder: Path) -> float:
    """Wall time (s) of one ``pipeline run`` of the spec in ``folder`` (a fresh state)."""
    for old in folder.glob("s*.tif*"):
        old.unlink()
    for state in folder.glob(".spec.state.json"):
        state.unlink()
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "unerode_cli", "pipeline", "run", str(folder / "spec.yaml"), "-qq"],
                   check=True)
    return time.perf_counter() - start


def _case():
    folder = Path(tempfile.mkdtemp(prefix="unerode-bench-pipeline-"))
    _spec(folder)
    run_once(folder)                                    # compile or load the kernels

    def work() -> None:
        run_once(folder)

    return work, STEPS, "steps"


if __name__ != "__main__":
    from harness import benchmark

    benchmark(NAME)(_case)
else:
    where = Path(tempfile.mkdtemp(prefix="unerode-bench-pipeline-"))
    _spec(where)
    run_once(where)
    walls = sorted(run_once(where) for _ in range(3))
    print(f"{NAME}: median {walls[1]:.2f} s, {walls[1] / STEPS * 1e3:.0f} ms per step")
