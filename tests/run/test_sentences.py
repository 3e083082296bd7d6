"""One sentence instead of exception text (issue 45, class 4) and messages that say what is
wrong (class 7): malformed EXR header attributes, a parameter that makes a process's stable time
step vanish, elevations too extreme to compute with, a parameter text that is neither a number
nor a file, snapshots outside the run, and Ctrl-C inside particle-erode's numba kernels.

Each command case asserts the exit code, a phrase of the one sentence on stderr, no Python class
name, and that the folder is left as it was (no output, no temporary)."""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from affine import Affine
from tests.conftest import SAMPLE_DEMS, write_geotiff
from tests.refusals import CLASS_NAME, cli, snapshot

from unerode_cli.errors import InputError, RunFailure
from unerode_cli.run.divergence import DivergenceGuard
from unerode_cli.run.runner import Change, StepApplier

CHRONOLOGY = "age_ka,d18o\n0,3.2\n5,3.5\n10,4.0\n15,4.6\n20,4.9\n25,4.7\n30,4.4\n"


def assert_one_sentence(stderr: str, phrase: str, absent: str = "") -> None:
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    assert lines[0].startswith("error: ") and lines[0].rstrip().endswith("."), stderr
    assert not re.search(CLASS_NAME, stderr), stderr
    assert phrase.lower() in lines[0].lower(), stderr
    if absent:
        assert absent not in lines[0], stderr


def assert_fails(folder: Path, args: tuple[object, ...], code: int, phrase: str, absent: str = "") -> None:
    """The command exits ``code`` with one sentence containing ``phrase`` (and not ``absent``)
    and leaves every file of ``folder`` as it was."""
    before = snapshot(folder)
    got, stderr = cli(folder, *args)
    assert got == code, stderr
    assert_one_sentence(stderr, phrase, absent)
    assert snapshot(folder) == before


def ramp(rows: int = 24, cols: int = 24) -> np.ndarray:
    r, c = np.indices((rows, cols))
    return 100.0 + 3.0 * (rows - 1 - r) + 2.0 * np.sin(c * 0.9) * np.cos(r * 0.7)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """A folder with ``in.tif``, a 24 × 24 ramp (UTM 32N, 30 m), and ``c.csv``, a δ18O chronology."""
    write_geotiff(tmp_path / "in.tif", ramp().astype(np.float32))
    (tmp_path / "c.csv").write_text(CHRONOLOGY)
    return tmp_path


# --- EXR header attributes ---------------------------------------------------------------------

def write_exr(path: Path, **attributes: str) -> Path:
    """A 16 × 16 float32 EXR heightfield whose ``unerode.*`` header attributes are ``attributes``."""
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
              **{f"unerode.{key}": value for key, value in attributes.items()}}
    pixels = np.ascontiguousarray(ramp(16, 16), dtype=np.float32)
    OpenEXR.File(header, {"Y": pixels}).write(str(path))
    return path


GOOD = {"transform": "[30, 0, 500000, 0, -30, 5000000]", "cellSize": "30 30", "nodata": "null", "tags": "{}"}


@pytest.mark.parametrize(("name", "value"), [
    ("transform", "[30, 0, 0,"),                 # not JSON
    ("transform", "[30, 0, 0]"),                 # JSON, but not 6 coefficients
    ("transform", '["a", 0, 0, 0, -30, 0]'),     # not numbers
    ("cellSize", "thirty"),
    ("cellSize", "30"),
    ("cellSize", "-30 30"),
    ("nodata", "{"),
    ("nodata", '"none"'),
    ("tags", "[1, 2"),
    ("tags", "[1, 2]"),
])
def test_a_malformed_exr_header_attribute_is_named_in_one_sentence(folder: Path, name: str,
                                                                   value: str) -> None:
    write_exr(folder / "bad.exr", **{**GOOD, name: value})
    phrase = f"header attribute unerode.{name} of bad.exr is malformed"
    assert_fails(folder, ("info", "bad.exr"), 2, phrase)
    assert_fails(folder, ("convert", "bad.exr", "out.tif"), 2, phrase)


def test_a_well_formed_exr_header_is_read(folder: Path) -> None:
    write_exr(folder / "good.exr", **GOOD)
    code, stderr = cli(folder, "convert", "good.exr", "out.tif")
    assert code == 0, stderr
    import rasterio

    with rasterio.open(folder / "out.tif") as src:
        assert src.transform == Affine(30, 0, 500000, 0, -30, 5000000)


def test_a_truncated_exr_is_one_sentence_and_the_library_prints_nothing(folder: Path) -> None:
    """The OpenEXR library prints a warning on stdout and a line per damaged chunk on stderr
    (file descriptors 1 and 2, below Python): silenced, one sentence remains."""
    (folder / "cut.exr").write_bytes((SAMPLE_DEMS / "fractal_30m.exr").read_bytes()[:3000])
    before = snapshot(folder)
    result = subprocess.run([sys.executable, "-m", "unerode_cli", "info", "cut.exr"], cwd=folder,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2, result.stderr
    assert result.stdout == ""
    assert_one_sentence(result.stderr, "cut.exr is not an OpenEXR file that can be read")
    assert snapshot(folder) == before


# --- parameter values that are neither numbers nor files ---------------------------------------

@pytest.mark.parametrize(("args", "phrase"), [
    (("erode", "in.tif", "out.tif", "--K", "1e-5x", "--steps", "2"),
     "'1e-5x', neither a number nor a raster"),
    (("erode", "in.tif", "out.tif", "--K", "k.tif", "--steps", "2"),
     "'k.tif', neither a number nor a raster"),
    (("flow", "in.tif", "q.tif", "-p", "1e-5x"),
     "parameter precipitation (--precipitation) is '1e-5x', neither a number"),
    (("glaciate", "in.tif", "out.tif", "--ela", "15O0", "--duration", "20"),
     "'15O0', neither a number nor a raster or a CSV table"),
    ((*("climate-run", "in.tif", "out.tif", "--chronology", "c.csv", "--to", "2", "--dt", "1000"),
      "--uplift", "1e-4y"),
     "'1e-4y', neither a number nor a raster or a CSV table"),
])
def test_a_parameter_typo_is_neither_a_number_nor_a_file(folder: Path, args: tuple[str, ...],
                                                          phrase: str) -> None:
    assert_fails(folder, args, 2, phrase, absent="does not exist")


# --- stable time steps and extreme elevations --------------------------------------------------

def test_a_rate_that_leaves_no_stable_time_step_is_refused_before_any_step(folder: Path) -> None:
    for command in ("unerode", "erode"):
        assert_fails(folder, (command, "in.tif", "out.tif", "--K", "1e308", "--steps", "2"), 2,
                     "the fluvial process has no stable time step", absent="non-positive")


class _Process:
    """A process whose stable step is ``stables[i]`` at its i-th question; it changes nothing."""

    name = "fake"

    def __init__(self, *stables: float) -> None:
        self.stables = list(stables)

    def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
        return self.stables.pop(0)

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        return Change(np.zeros_like(elevation), 0.0, 0.0, 0.0)


@pytest.mark.parametrize("stable", [0.0, -1.0, math.nan])
def test_no_stable_step_is_bad_input_before_any_change_and_a_failed_run_after(stable: float) -> None:
    h = np.zeros((3, 3))
    with pytest.raises(InputError, match="no stable time step on this terrain"):
        StepApplier([_Process(stable)], 10.0).step(h, 1)
    applier = StepApplier([_Process(math.inf, 5.0, stable)], 10.0)
    applier.step(h, 1)
    applier.step(h, 2)                       # two sub-steps of 5 y
    assert applier.report.substeps == {"fake": 3}
    with pytest.raises(RunFailure, match="became unstable in step 3"):
        applier.step(h, 3)


def test_elevations_whose_relief_overflows_are_refused_before_the_first_step(folder: Path) -> None:
    z = np.zeros((24, 24))
    z[::2, ::2], z[1::2, 1::2] = 1e308, -1e308
    write_geotiff(folder / "x.tif", z)
    assert_fails(folder, ("erode", "x.tif", "out.tif", "--process", "thermal", "--steps", "2", "--force"), 2,
                 "a relief too large to compute with")
    with pytest.raises(InputError, match="relief too large"):
        DivergenceGuard(z)


@pytest.mark.parametrize("command", [("particle-erode", "--particles", "5", "--iterations", "1"),
                                     ("glaciate", "--ela", "150", "--duration", "20", "--force")])
def test_other_stepping_commands_refuse_an_overflowing_relief(folder: Path, command: tuple[str, ...]) -> None:
    z = np.zeros((24, 24))
    z[::2, ::2], z[1::2, 1::2] = 1e308, -1e308
    write_geotiff(folder / "x.tif", z)
    assert_fails(folder, (command[0], "x.tif", "out.tif", *command[1:]), 2, "a relief too large")


def test_a_precipitation_whose_discharge_overflows_float32_is_refused(folder: Path) -> None:
    assert_fails(folder, ("flow", "in.tif", "q.tif", "-p", "1e308"), 2,
                 "more than a float32 raster holds")
    assert_fails(folder, ("flow", "in.tif", "q.tif", "-p", "1e36"), 2, "could give discharges above")


def test_a_difference_beyond_float32_asks_for_float64(folder: Path) -> None:
    write_geotiff(folder / "high.tif", np.full((24, 24), 3e38, dtype=np.float32))
    write_geotiff(folder / "low.tif", np.full((24, 24), -3e38, dtype=np.float32))
    assert_fails(folder, ("diff", "high.tif", "low.tif", "d.tif"), 2, "write it with --dtype float64")
    code, stderr = cli(folder, "diff", "high.tif", "low.tif", "d.tif", "--dtype", "float64")
    assert code == 0, stderr
    assert not re.search(CLASS_NAME, stderr) and "warning" not in stderr, stderr


def test_a_thermal_run_that_becomes_non_finite_is_the_divergence_sentence(folder: Path) -> None:
    z = ramp()
    z[12, 12] = 1e300
    write_geotiff(folder / "spike.tif", z)
    assert_fails(folder, ("erode", "spike.tif", "out.tif", "--process", "thermal", "--steps", "2", "--force"),
                 1, "the run diverged in step 1")


# --- snapshots outside the run -----------------------------------------------------------------

CLIMATE = ("climate-run", "in.tif", "out.tif", "--chronology", "c.csv", "--to", "2", "--dt", "1000")


@pytest.mark.parametrize(("age", "phrase"), [
    ("500", "snapshot age 500 ka is outside the run, which spans 0 → 2 ka"),
    ("-1", "snapshot age -1 ka is outside the run"),
    ("1.5", "snapshot age 1.5 ka is not the end of a step of the run"),
])
def test_a_climate_run_snapshot_outside_the_run_says_so(folder: Path, age: str, phrase: str) -> None:
    assert_fails(folder, (*CLIMATE, "--snapshots", age), 2, phrase)


def test_a_glaciate_snapshot_interval_longer_than_the_run_says_so(folder: Path) -> None:
    assert_fails(folder, ("glaciate", "in.tif", "out.tif", "--ela", "150", "--duration", "20",
                          "--snapshot-every", "100"), 2,
                 "--snapshot-every 100 years is outside the run, which lasts 20 years")


# --- Ctrl-C inside particle-erode's kernels ----------------------------------------------------

def test_a_deferred_interrupt_raises_between_batches_and_a_second_at_once() -> None:
    from unerode_cli.jobs.particle_erode.interrupts import deferred_interrupt

    before = signal.getsignal(signal.SIGINT)
    with deferred_interrupt() as deferred:
        deferred.check()                                  # nothing received: no interrupt
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)                                  # the handler only records it
        assert deferred.signals == 1
        with pytest.raises(KeyboardInterrupt):
            deferred.check()
        with pytest.raises(KeyboardInterrupt):            # the user insists: at once
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)
    assert signal.getsignal(signal.SIGINT) is before


def test_an_exception_caused_by_an_interrupt_is_recognised() -> None:
    from unerode_cli.run.unexpected import interrupt_cause

    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as inner:
            raise SystemError("CPUDispatcher(<function trace_batch>) returned a result with an "
                              "exception set") from inner
    except SystemError as exc:
        assert interrupt_cause(exc)
    assert not interrupt_cause(ValueError("plain"))


def test_particle_iterations_stop_where_between_batches_raises() -> None:
    from unerode_cli.grid import Grid
    from unerode_cli.particles import Emission, HeightfieldTerrain, ParticleKind, preset_params
    from unerode_cli.particles.simulate import ParticleIterations

    calls = []

    def between() -> None:
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt

    grid = Grid.full(ramp().shape, 30.0)
    kind = ParticleKind(preset_params("rain", 30.0), Emission.rain(50), name="rain")
    steps = ParticleIterations(HeightfieldTerrain(ramp(), grid), (kind,), iterations=3,
                               between_batches=between)
    steps.iterate()
    with pytest.raises(KeyboardInterrupt):
        steps.iterate()
    assert steps.done == 1


def test_ctrl_c_in_particle_erode_exits_130_with_the_interrupt_sentence(tmp_path: Path) -> None:
    """SIGINT after the second checkpoint, while the kernels run: exit 130, the interrupt
    sentence naming the checkpoint kept, no numba error, no output."""
    dem = tmp_path / "big.tif"
    dem.write_bytes((SAMPLE_DEMS / "eroded_utm32n_30m.tif").read_bytes())
    checkpoint = tmp_path / ".out.tif.checkpoint.npz"
    process = subprocess.Popen(
        [sys.executable, "-m", "unerode_cli", "particle-erode", "big.tif", "out.tif", "--particles", "4000",
         "--iterations", "100000", "--checkpoint-every", "1"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen: set[float] = set()
    deadline = time.monotonic() + 240
    while len(seen) < 2 and time.monotonic() < deadline and process.poll() is None:
        if checkpoint.exists():
            seen.add(checkpoint.stat().st_mtime)
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 130, stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted"), stderr
    assert not re.search(CLASS_NAME, stderr), stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.tif.checkpoint.npz", "big.tif"]


# --- absurd sizes met in the jobs above ----------------------------------------------------------

def test_a_climate_run_of_absurdly_many_steps_is_refused_at_once(folder: Path) -> None:
    start = time.perf_counter()
    assert_fails(folder, ("climate-run", "in.tif", "out.tif", "--chronology", "c.csv", "--to", "20",
                          "--dt", "1e-300"), 2, "time steps")
    assert time.perf_counter() - start < 10.0


def test_a_search_radius_past_the_dem_finishes(folder: Path) -> None:
    write_geotiff(folder / "past_1ka.tif", ramp().astype(np.float32))
    (folder / "obs.csv").write_text("age_ka,height_above_river_m\n1,5\n")
    start = time.perf_counter()
    code, stderr = cli(folder, "compare-terraces", "--present", "in.tif", "--snapshots", "past_1ka.tif",
                       "--auto-river", "--out", "rep", "--observations", "obs.csv",
                       "--search-radius", "1e308")
    assert code in (0, 2), stderr
    assert time.perf_counter() - start < 10.0
    assert not re.search(CLASS_NAME, stderr), stderr
