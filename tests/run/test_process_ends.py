"""A command's work ends with its job: a job run in process leaves no thread behind and nothing
that keeps a core busy (numba's OpenMP workers, a progress bar's refresh thread, a cluster).
The time from a command's last file to its exit is measured by bench/bench_exit_after_write.py
(the interpreter's shutdown: 1.5–3.9 s on 2 busy cores, 0.6–0.9 CPU s)."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest
from tests.refusals import cli

from unerode_cli.io.rasters import read_terrain


@pytest.fixture(scope="module")
def mountain(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, float]:
    """A 48 × 48 synthetic range of 100 m cells (synth's default relief) and an ELA at 60 % of
    its height."""
    folder = tmp_path_factory.mktemp("ends")
    code, stderr = cli(folder, "synth", "dem.tif", "--size", 48, "--dx", 100, "--seed", 2, "-q")
    assert code == 0, stderr
    z = read_terrain(folder / "dem.tif").elevation
    return folder / "dem.tif", float(0.6 * z.max())


def cpu_seconds() -> float:
    times = os.times()
    return times.user + times.system


COMMANDS = {
    "glaciate": lambda dem, ela: ("glaciate", dem, "out.tif", "--ela", f"{ela:.0f}", "--duration", "200",
                                  "--dt", "50", "--flow-rtol", "0.03", "--ice", "ice.tif",
                                  "--velocity", "v.tif", "--preview", "out.png", "-q"),
    "erode": lambda dem, ela: ("erode", dem, "out.tif", "--duration", "5000", "--dt", "500",
                               "--change-map", "change.tif", "--preview", "out.png", "-q"),
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_job_run_in_process_leaves_nothing_running(tmp_path: Path, mountain: tuple[Path, float],
                                                     command: str) -> None:
    before = set(threading.enumerate())
    code, stderr = cli(tmp_path, *COMMANDS[command](*mountain))
    assert code == 0, stderr
    assert set(threading.enumerate()) == before
    start = cpu_seconds()
    time.sleep(1.0)
    assert cpu_seconds() - start < 0.05          # nothing spins once the job has returned
