"""`unerode-cli ensemble`: members in their folders, identical members bit-identical, the
summary equal to NumPy's statistics of the member rasters, ranking by the terrace fit, failures
recorded, resume after SIGKILL, a real scheduler, and bad input refused."""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli
from tests.ensemble.case import SEA_LEVELS, needs_data, write_case
from tests.ensemble.html_check import check_page
from tests.ensemble.summary_check import assert_summaries_match_members

pytestmark = pytest.mark.skipif(not needs_data, reason="needs ../shared/data (LR04, sea-level curves)")

#: Members 0 and 1 have the same parameters; 2 and 3 differ in K and the sea-level curve.
SWEEP = (f"  past.K: [2.0e-5, 2.0e-5, 3.0e-5]\n"
         f"  past.sea-level: [{SEA_LEVELS['spratt']}, {SEA_LEVELS['bintanja']}]\n")
STATISTICS = ("mean", "std", "p5", "p50", "p95")


def read(path: Path) -> np.ndarray:
    with rasterio.open(path) as src:
        return src.read(1).astype(np.float64)


def table(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope="module")
def ensemble_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, subprocess.CompletedProcess]:
    folder = tmp_path_factory.mktemp("ensemble")
    spec = write_case(folder, SWEEP)
    out = folder / "out"
    result = run_cli("ensemble", spec, out, "--workers", "2", "--report")
    return spec, out, result


def test_every_member_runs_in_its_folder(ensemble_run) -> None:
    _, out, result = ensemble_run
    assert result.returncode == 0, result.stderr
    assert "local cluster: 2 worker(s) × 1 numba thread(s)" in result.stderr
    assert "ensemble: 6 of 6 member(s) finished" in result.stderr.strip().splitlines()[-1]
    for i in range(6):
        member = out / "members" / f"{i:04d}"
        record = json.loads((member / "member.json").read_text())
        assert record["index"] == i
        assert record["parameters"]["past.K"] == [2.0e-5, 2.0e-5, 3.0e-5][i // 2]
        assert record["parameters"]["past.sea-level"] == str(list(SEA_LEVELS.values())[i % 2])
        assert (member / "done.json").exists() and (member / "report" / "summary.json").exists()
        assert f"--k {record['parameters']['past.K']}" in (member / "member.log").read_text().lower()
    assert table(out / "failures.csv") == []


def test_members_with_the_same_parameters_are_bit_identical(ensemble_run) -> None:
    _, out, _ = ensemble_run
    for name in ("past.tif", "past_10ka.tif"):
        a, b = read(out / "members/0000" / name), read(out / "members/0002" / name)
        assert np.array_equal(a, b)
        assert not np.array_equal(a, read(out / "members/0001" / name))   # another sea-level curve
        assert not np.array_equal(a, read(out / "members/0004" / name))   # another K


def test_summary_rasters_equal_numpy_statistics_of_the_members(ensemble_run) -> None:
    _, out, _ = ensemble_run
    for stem in ("past", "past_10ka"):
        assert_summaries_match_members(out, stem, 6)
        with rasterio.open(out / "summary" / f"{stem}_p50.tif") as src, \
                rasterio.open(out / "members/0000" / f"{stem}.tif") as member:
            assert float(src.tags()["UNERODE_AGE_KA"]) == float(member.tags()["UNERODE_AGE_KA"])
    assert read(out / "summary" / "past_std.tif").max() > 0.1


def test_the_snapshot_statistics_are_one_cf_netcdf_time_series(ensemble_run) -> None:
    xarray = pytest.importorskip("xarray")
    _, out, result = ensemble_run
    assert "2 age(s) also in snapshots.nc" in result.stderr
    with xarray.open_dataset(out / "summary" / "snapshots.nc") as ds:
        assert ds.attrs["Conventions"] == "CF-1.8"
        assert ds["age"].values.tolist() == [20.0, 10.0]          # past.tif ends at 20 ka
        assert ds["time"].values.tolist() == [-20000.0, -10000.0] and ds["time"].attrs["units"] == "year"
        assert ds["elevation_mean"].attrs["cell_methods"] == "realization: mean"
        assert ds["elevation_std"].attrs["units"] == "m" and "crs" in ds.variables
        for k, stem in enumerate(("past", "past_10ka")):
            for name in STATISTICS:
                expected = read(out / "summary" / f"{stem}_{name}.tif").astype(np.float32)
                assert np.allclose(ds[f"elevation_{name}"].values[k], expected, atol=1e-3), (stem, name)


def test_members_are_ranked_by_their_terrace_rmse(ensemble_run) -> None:
    _, out, _ = ensemble_run
    rows = table(out / "members.csv")
    assert [int(r["rank"]) for r in rows] == list(range(1, 7))
    rmse = [float(r["terrace_rmse_m"]) for r in rows]
    assert rmse == sorted(rmse)
    for row in rows:
        summary = json.loads((out / row["folder"] / "report" / "summary.json").read_text())
        assert float(row["terrace_rmse_m"]) == pytest.approx(summary["terraces"]["rmse_m"], rel=1e-12)
        assert float(row["past.K"]) in (2.0e-5, 3.0e-5)
    best = json.loads((out / "summary" / "best.json").read_text())["members"]
    assert best[0]["member"] == int(rows[0]["member"])
    assert best[0]["terrace_rmse_m"] == pytest.approx(rmse[0], rel=1e-12)
    for key in ("past.K", "past.sea-level"):
        assert (out / "summary" / f"scatter_{key}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "report.html").stat().st_size > 50_000


def test_the_reports_of_the_ensemble_and_of_a_member(ensemble_run, tmp_path: Path) -> None:
    _, out, _ = ensemble_run
    page = check_page((out / "report.html").read_text(encoding="utf-8"), out)
    assert [h for h in page.headings if h in ("Ensemble", "Members, best first", "Summary maps",
                                              "Terrace fits", "Parameters against scores")] == \
        ["Ensemble", "Members, best first", "Summary maps", "Terrace fits", "Parameters against scores"]
    # at 10 and 20 ka: median, spread, median and best member minus the present; the terrace
    # spread, the best and the median member's profiles; the pair matrix and 2 scatter plots
    assert len(page.images) == 2 * 4 + 3 + 3
    ranking = next(t for t in page.tables if t[0][:3] == ["rank", "member", "status"])
    first = table(out / "members.csv")[0]
    assert ranking[1][1] == first["member"]
    assert float(ranking[1][5]) == pytest.approx(float(first["terrace_rmse_m"]), rel=1e-5)
    member = out / "members" / f"{int(first['member']):04d}"
    result = run_cli("report", member, "--output", tmp_path / "member.html")
    assert result.returncode == 0, result.stderr
    page = check_page((tmp_path / "member.html").read_text(encoding="utf-8"))
    assert "compare-terraces report/" in page.headings and "climate-run past.tif" in page.headings
    fit = next(t for t in page.tables if t[1][0] == "terraces compared")
    assert float(fit[2][1]) == pytest.approx(float(first["terrace_rmse_m"]), rel=1e-5)


def test_a_failing_member_is_recorded_and_the_others_finish(tmp_path: Path) -> None:
    # dt 3000 does not divide the 20 ka run (the step refuses it when it runs); dt -5 is
    # refused by the spec's checks before it runs; dt 5000 runs
    spec = write_case(tmp_path, "  past.dt: [5000, 3000, -5]\n")
    result = run_cli("ensemble", spec, tmp_path / "out", "--workers", "1", "-q")
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "1 of 3 member(s) finished, 2 failed (see failures.csv)" in lines[0]
    failures = table(tmp_path / "out" / "failures.csv")
    assert [int(f["member"]) for f in failures] == [1, 2]
    assert failures[0]["step"] == "past" and "whole number" in failures[0]["error"]
    assert "must be > 0 years" in failures[1]["error"]
    assert (tmp_path / "out" / "members/0000/done.json").exists()
    assert not (tmp_path / "out" / "members/0001/done.json").exists()
    assert [r["status"] for r in table(tmp_path / "out" / "members.csv")] == ["finished", "failed", "failed"]


@pytest.mark.slow
def test_resume_after_sigkill_keeps_finished_members(tmp_path: Path, ensemble_run) -> None:
    """Killed once two members are done; --resume leaves them untouched and gives the summary
    of the uninterrupted run (which ran on 2 workers × 1 thread, this one on 1 × 2)."""
    _, reference, _ = ensemble_run
    spec = write_case(tmp_path, SWEEP)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "unerode_cli", "ensemble", str(spec), str(out), "--workers", "1"]
    process = subprocess.Popen(command, stderr=subprocess.DEVNULL, start_new_session=True)
    done: list[Path] = []
    deadline = time.monotonic() + 240
    while len(done) < 2 and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
        done = sorted(out.glob("members/*/done.json"))
    os.killpg(process.pid, signal.SIGKILL)       # the command and its dask workers
    process.wait()
    assert 2 <= len(done) < 6, "the ensemble finished before it could be killed"
    finished = [p.parent for p in done]
    stamps = {p: p.stat().st_mtime_ns for member in finished for p in member.iterdir() if p.is_file()}
    result = run_cli("ensemble", spec, out, "--workers", "1", "--resume")
    assert result.returncode == 0, result.stderr
    assert f"{len(finished)} finished earlier" in result.stderr
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    for name in STATISTICS:
        for stem in ("past", "past_10ka"):
            a = read(out / "summary" / f"{stem}_{name}.tif")
            assert np.array_equal(a, read(reference / "summary" / f"{stem}_{name}.tif"))
    timeless = lambda path: [{k: v for k, v in row.items() if k != "wall_s"} for row in table(path)]  # noqa: E731
    assert timeless(out / "members.csv") == timeless(reference / "members.csv")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_real_scheduler_and_worker(tmp_path: Path) -> None:
    dask = Path(sys.executable).with_name("dask")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler = subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                  "--dashboard-address", ":0", "--no-show"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    worker = subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--nworkers", "1",
                               "--no-dashboard", "--host", "127.0.0.1"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    try:
        spec = write_case(tmp_path, SWEEP.splitlines(keepends=True)[1])
        result = run_cli("ensemble", spec, tmp_path / "out", "--scheduler", address,
                         "--scheduler-timeout", "30")
    finally:
        for process in (worker, scheduler):
            process.terminate()
            process.wait(timeout=30)
    assert result.returncode == 0, result.stderr
    assert f"scheduler {address}: 1 worker(s)" in result.stderr
    assert len(table(tmp_path / "out" / "members.csv")) == 2
    assert all((tmp_path / "out" / f"members/000{i}/done.json").exists() for i in range(2))


@pytest.mark.parametrize(("sweep", "options", "mentions"), [
    ("  past.K-x: [1.0e-5]\n", [], "climate-run has no option --K-x"),
    ("  nowhere: [1]\n", [], "no step's subcommand has an option --nowhere"),
    ("  past.K: {uniform: [2.0e-5, 1.0e-5]}\n", ["--members", "4"], "is empty"),
    ("  past.K: {uniform: [1.0e-5, 2.0e-5]}\n", ["--members", "0"], "--members"),
    ("  past.K: [1.0e-5]\n", ["--scheduler", "tcp://127.0.0.1:9", "--scheduler-timeout", "1"],
     "does not answer"),
])
def test_bad_input(tmp_path: Path, sweep: str, options: list[str], mentions: str) -> None:
    spec = write_case(tmp_path, sweep)
    started = time.monotonic()
    result = run_cli("ensemble", spec, tmp_path / "out", *options)
    assert_refused(result, None, mentions)
    assert time.monotonic() - started < 30
    assert not (tmp_path / "out").exists()
