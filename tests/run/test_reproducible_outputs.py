"""Two identical runs give byte-identical rasters and tables (issue 45, class 9).

The history tag of a raster holds no time (the time is in the sidecar only); the mass budget of
the fluvial step is summed in an order that does not depend on the number of numba threads; with
``SOURCE_DATE_EPOCH`` set the sidecars (and a pipeline's state file) are identical too.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
import rasterio
from tests.conftest import SHARED_DATA, write_geotiff

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"


def run(*args: object, cwd: Path, threads: int = 1, epoch: str | None = None) -> None:
    """``unerode-cli ARGS`` in its own interpreter in ``cwd`` with ``threads`` numba threads
    (and ``SOURCE_DATE_EPOCH`` when given); it must succeed."""
    env = {k: v for k, v in os.environ.items() if k != "SOURCE_DATE_EPOCH"}
    env["NUMBA_NUM_THREADS"] = str(threads)
    if epoch is not None:
        env["SOURCE_DATE_EPOCH"] = epoch
    cwd.mkdir(parents=True, exist_ok=True)
    result = subprocess.run([sys.executable, "-m", "unerode_cli", *map(str, args)], cwd=cwd, env=env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr


def contents(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def valley(tmp_path: Path) -> Path:
    """A 64 × 64 V-shaped valley with some noise, draining north (UTM, 30 m)."""
    rows, cols = np.mgrid[0:64, 0:64].astype(float)
    noise = np.random.default_rng(4).random((64, 64))
    z = 5.0 + 3.0 * rows + 2.0 * np.abs(cols - 32.0) + 4.0 * noise
    return write_geotiff(tmp_path / "valley.tif", z.astype(np.float32))


def test_the_fluvial_budget_does_not_depend_on_the_number_of_threads() -> None:
    from unerode_cli.processes.fluvial_kernels import settle_into

    threads = numba.config.NUMBA_NUM_THREADS
    if threads < 2:
        pytest.skip("needs two numba threads")
    rng = np.random.default_rng(0)
    n = 100_003                                  # several blocks of the sums, the last one short
    order = rng.permutation(n).astype(np.int64)
    net, qs, outlets = rng.normal(size=n) * 1e-3, rng.random(n), rng.random(n) < 0.01
    results = []
    for count in (1, threads):
        numba.set_num_threads(count)
        dh = np.zeros(n)
        results.append((settle_into(order, net, qs, outlets, np.array([1e-4]), 1000.0, 900.0, dh), dh))
    numba.set_num_threads(threads)
    assert results[0][0] == results[1][0]       # to the last bit
    assert np.array_equal(results[0][1], results[1][1])
    eroded = np.sum(np.maximum(net[~outlets[order]], 0.0)) * 900.0
    assert results[0][0][0] == pytest.approx(eroded, rel=1e-12)


def test_two_erode_runs_give_identical_rasters_and_the_time_is_in_the_sidecar_only(
        tmp_path: Path, valley: Path) -> None:
    args = ("erode", valley, "out.tif", "--steps", 3, "--dt", 1000, "--process", "fluvial,thermal",
            "--change-map", "change.tif")
    run(*args, cwd=tmp_path / "a", threads=1)
    run(*args, cwd=tmp_path / "b", threads=2)
    a, b = contents(tmp_path / "a"), contents(tmp_path / "b")
    assert a.keys() == b.keys() and {"out.tif", "out.tif.json", "change.tif"} <= set(a)
    for name in ("out.tif", "change.tif"):
        assert a[name] == b[name], name
    with rasterio.open(tmp_path / "a" / "out.tif") as src:
        history = json.loads(src.tags()["UNERODE_HISTORY"])
    assert "time" not in history[-1] and history[-1]["command"] == "erode"
    sidecar = json.loads(a["out.tif.json"])
    assert "time" in sidecar and "wall_time_s" in sidecar["statistics"]

    # with SOURCE_DATE_EPOCH the sidecars are identical too, with that time
    run(*args, "--overwrite", cwd=tmp_path / "a", threads=1, epoch="1700000000")
    run(*args, "--overwrite", cwd=tmp_path / "b", threads=2, epoch="1700000000")
    a, b = contents(tmp_path / "a"), contents(tmp_path / "b")
    assert a == b
    sidecar = json.loads(a["out.tif.json"])
    assert sidecar["time"] == "2023-11-14T22:13:20+00:00"
    assert "wall_time_s" not in sidecar["statistics"]


@pytest.mark.skipif(not LR04.exists(), reason="needs ../shared/data")
def test_two_climate_runs_give_identical_timelines_whatever_the_threads(tmp_path: Path, valley: Path) -> None:
    args = ("climate-run", valley, "past.tif", "--chronology", LR04, "--from", 0, "--to", 6, "--dt", 1000,
            "--process", "thermal,fluvial", "--snapshots", 3)
    run(*args, cwd=tmp_path / "a", threads=1, epoch="0")
    run(*args, cwd=tmp_path / "b", threads=2, epoch="0")
    a, b = contents(tmp_path / "a"), contents(tmp_path / "b")
    assert {"past.tif", "past_3ka.tif", "past_timeline.csv"} <= set(a)
    assert a == b                                # eroded_m3 to the last digit, sidecars included
    rows = (tmp_path / "a" / "past_timeline.csv").read_text().splitlines()
    assert rows[0].split(",").count("eroded_m3") == 1 and len(rows) == 7


def test_a_pipeline_run_in_two_folders_writes_identical_files(tmp_path: Path, valley: Path) -> None:
    """The history of a step's output names the workdir's files relative to it, so the same
    spec run in two folders writes the same bytes; with SOURCE_DATE_EPOCH its state file too."""
    spec = ("version: 1\nsteps:\n"
            "  - {name: eroded, run: erode, args: [valley.tif, eroded.tif], options: {steps: 2}}\n"
            "  - {name: copy, run: convert, args: [\"${steps.eroded.output}\", copy.tif]}\n")
    for name in ("a", "b"):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "valley.tif").write_bytes(valley.read_bytes())
        (folder / "p.yaml").write_text(spec)
    run("pipeline", "run", "p.yaml", cwd=tmp_path / "a", threads=1, epoch="0")
    run("pipeline", "run", "p.yaml", cwd=tmp_path / "b", threads=2, epoch="0")
    a, b = contents(tmp_path / "a"), contents(tmp_path / "b")
    assert {"eroded.tif", "copy.tif", ".p.state.json"} <= set(a)
    assert a == b
    with rasterio.open(tmp_path / "a" / "copy.tif") as src:
        history = json.loads(src.tags()["UNERODE_HISTORY"])
    assert history[0]["command_line"].startswith("unerode-cli erode valley.tif eroded.tif")
