"""Nothing lost, nothing half-written: diverging runs stop before writing, every file a command
writes (sidecars included) is cleared before any work, interrupted runs say what they left."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.windows import Window
from tests.cli.test_bad_input import assert_refused
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, run_cli, write_geotiff

from unerode_cli.errors import InputError, RunFailure
from unerode_cli.io import paths
from unerode_cli.run.divergence import FLOOR_M, RELIEF_FACTOR, DivergenceGuard
from unerode_cli.run.runner import Change, run

VALLEY = SAMPLE_DEMS / "valley_utm32n_30m.tif"
LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"


@pytest.fixture
def ramp(tmp_path: Path) -> Path:
    rows, cols = np.indices((24, 20))
    z = 10.0 + 2.0 * (23 - rows) + 0.5 * np.sin(cols)
    return write_geotiff(tmp_path / "ramp.tif", z.astype(np.float32))


def crop(path: Path, size: int, out: Path) -> Path:
    """The top-left ``size`` × ``size`` cells of a GeoTIFF."""
    with rasterio.open(path) as src:
        window = Window(0, 0, size, size)
        data = src.read(1, window=window)
        profile = src.profile | {"width": size, "height": size, "transform": src.window_transform(window)}
    with rasterio.open(out, "w", **profile) as dst:
        dst.write(data, 1)
    return out


def files_in(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


# --- 1. diverging runs ----------------------------------------------------------------------------

def test_the_guard_allows_a_multiple_of_the_relief_and_the_uplift() -> None:
    start = np.array([[0.0, 100.0], [50.0, np.nan]])
    guard = DivergenceGuard(start, uplift_rate=0.01)
    assert guard.relief == 100.0
    assert guard.allowed_change(1000.0) == pytest.approx(RELIEF_FACTOR * 100.0 + FLOOR_M + 10.0)
    guard.check(start + 600.0, 1000.0, "here")             # 600 m ≤ 610 m: a sane run
    with pytest.raises(RunFailure, match="moved by 620 m"):
        guard.check(start + 620.0, 1000.0, "here")
    blown = start.copy()
    blown[0, 1] = np.inf
    with pytest.raises(RunFailure, match="NaN or infinite"):
        guard.check(blown, 1.0, "in step 3")
    outside = start.copy()
    outside[1, 1] = -1e30                                   # nodata cells are not looked at
    guard.check(outside, 1.0, "here")


class RunawayProcess:
    """Lowers every cell tenfold more each step: diverges at the 3rd step of a 10 m relief."""

    name = "runaway"

    def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
        return float("inf")

    def advance(self, elevation: np.ndarray, dt: float) -> Change:
        dh = -np.abs(elevation) * 10.0
        return Change(dh, 0.0, 0.0, 0.0)


def test_the_runner_stops_a_diverging_run_before_the_step_is_handed_on() -> None:
    h0 = np.array([[1.0, 11.0], [5.0, 8.0]])
    handed: list[int] = []
    with pytest.raises(RunFailure, match="in step 2 "):
        run(h0, [RunawayProcess()], 1.0, 10, on_step=lambda i, h: handed.append(i),
            guard=DivergenceGuard(h0))
    assert handed == [1]


def test_an_absurd_substep_count_is_refused_with_the_stable_step() -> None:
    class Stiff(RunawayProcess):
        def stable_dt(self, elevation: np.ndarray, dt: float) -> float:
            return 0.5

    with pytest.raises(InputError, match=r"2e\+300 runaway sub-steps \(stable: ≤ 0.5 years\)"):
        run(np.zeros((2, 2)), [Stiff()], 1e300, 1)


def test_a_diverging_glacier_run_exits_1_and_writes_nothing(tmp_path: Path) -> None:
    dem = crop(VALLEY, 64, tmp_path / "small.tif")
    before = files_in(tmp_path)
    result = run_cli("glaciate", dem, tmp_path / "out.tif", "--ela", 800, "--duration", 30,
                     "--iceflow", "sia", "--snapshot-every", 10, "--preview", tmp_path / "out.png",
                     # 001 Eq. 2 as printed: snow on the crop's steep walls feeds the runaway SIA ice
                     "--snow-slope-min", 90, "--snow-slope-max", 90)
    assert result.returncode == 1, result.stderr
    assert "diverged" in result.stderr and "Traceback" not in result.stderr
    assert files_in(tmp_path) == before


# --- 2. sidecars (and every other file) are outputs -------------------------------------------------

@pytest.mark.parametrize("command, extra, sidecar", [
    ("erode", ["--steps", 1, "--dt", 100], "out.tif.json"),
    ("erode", ["--steps", 2, "--dt", 100, "--snapshot-every", 100], "out_001.tif.json"),
    ("erode", ["--steps", 1, "--dt", 100, "--change-map", "dh.tif"], "dh.tif.json"),
    ("flow", [], "out.tif.json"),
    ("convert", [], "out.tif.json"),
])
def test_an_existing_sidecar_is_refused_before_any_work(
        tmp_path: Path, ramp: Path, command: str, extra: list, sidecar: str) -> None:
    precious = tmp_path / sidecar
    precious.write_text("precious")
    args = [str(tmp_path / a) if isinstance(a, str) and a.endswith(".tif") else a for a in extra]
    result = run_cli(command, ramp, tmp_path / "out.tif", *args)
    assert_refused(result, tmp_path / "out.tif", "already exists")
    assert sidecar in result.stderr
    assert precious.read_text() == "precious"


def test_a_file_that_escaped_the_checks_is_never_replaced(tmp_path: Path) -> None:
    paths.forget_writes()
    target = tmp_path / "table.csv"
    target.write_text("precious")
    with pytest.raises(InputError, match="already exists"), paths.atomic_path(target) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "precious"
    paths.check_output(target, overwrite=True)
    with paths.atomic_path(target) as tmp:
        tmp.write_text("new")
    with paths.atomic_path(target) as tmp:                   # what this process wrote, it may rewrite
        tmp.write_text("newer")
    assert target.read_text() == "newer"
    assert paths.written_files() == [target, target]


# --- 3. everything checked before computing --------------------------------------------------------

@pytest.mark.parametrize("output, options, mentions", [
    ("out.exr", ["--cog"], "cog"),
    ("out.nosuchformat", [], "nosuchformat"),
    ("out.tif", ["--preview", "out.jpg"], ".png"),
])
def test_unwritable_outputs_are_refused_before_the_first_step(
        tmp_path: Path, ramp: Path, output: str, options: list[str], mentions: str) -> None:
    args = [str(tmp_path / o) if "." in o and not o.startswith("-") else o for o in options]
    started = time.perf_counter()
    result = run_cli("erode", ramp, tmp_path / output, "--steps", 100000, "--dt", 1, *args)
    assert time.perf_counter() - started < 60                 # refused, not computed
    assert_refused(result, tmp_path / output, mentions)
    assert files_in(tmp_path) == {"ramp.tif"}


def test_a_preview_of_one_cell_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    one = write_geotiff(tmp_path / "one.tif", np.array([[5.0]], dtype=np.float32))
    result = run_cli("erode", one, tmp_path / "out.tif", "--steps", 1, "--preview", tmp_path / "p.png")
    assert_refused(result, tmp_path / "out.tif", "2 × 2")
    assert files_in(tmp_path) == {"one.tif"}


@pytest.mark.skipif(not LR04.exists(), reason="needs ../shared/data")
def test_climate_run_refuses_an_unwritable_output_before_its_checkpoint(tmp_path: Path, ramp: Path) -> None:
    result = run_cli("climate-run", ramp, tmp_path / "past.nosuchformat", "--chronology", LR04,
                     "--from", 0, "--to", 50, "--dt", 1000)
    assert_refused(result, tmp_path / "past.nosuchformat")
    assert files_in(tmp_path) == {"ramp.tif"}


# --- 4. interrupted runs ---------------------------------------------------------------------------

def test_stale_temporaries_of_killed_writers_are_removed(tmp_path: Path, ramp: Path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    stale = tmp_path / f".out.{dead.stdout.strip()}.k3j2.part.tif"
    stale.write_bytes(b"half a raster")
    alive = tmp_path / f".out.{os.getpid()}.x9y8.part.tif"   # a writer that still runs: kept
    alive.write_bytes(b"being written")
    result = run_cli("erode", ramp, tmp_path / "out.tif", "--steps", 1)
    assert result.returncode == 0, result.stderr
    assert not stale.exists() and alive.exists()


def test_an_interrupted_run_names_the_files_it_left(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "out.tif"
    args = [sys.executable, "-m", "unerode_cli", "erode", str(ramp), str(out), "--dt", "1",
            "--steps", "20000", "--snapshot-every", "1"]
    # Ctrl-C in a terminal: SIGINT at its default disposition in the run, whatever the test
    # runner inherited (a shell without job control starts `cmd &` with SIGINT ignored, and
    # Python then installs no KeyboardInterrupt handler).
    process = subprocess.Popen(args, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 280                       # numba may compile the kernels first
    while not (tmp_path / "out_001.tif").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert (tmp_path / "out_001.tif").exists(), "no snapshot within the deadline"
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130
    assert "interrupted" in stderr and "out_001.tif" in stderr
    # the hint: --resume where the run left a checkpoint (slow machines reach one first), else --overwrite
    if (tmp_path / ".out.tif.checkpoint.npz").exists():
        assert "--resume to continue" in stderr and "--overwrite" not in stderr
    else:
        assert "--overwrite" in stderr
    assert not list(tmp_path.glob(".out*.part*"))
    rerun = run_cli("erode", ramp, out, "--dt", 1, "--steps", 2, "--snapshot-every", 1, "--overwrite")
    assert rerun.returncode == 0, rerun.stderr


def test_an_interrupt_between_a_temporary_and_its_clean_up_leaves_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C may land after ``mkdtemp`` made a staging folder and before its ``try``: the
    command's error handler still removes what this process left beside its outputs."""
    import typer

    from unerode_cli.cli.errors import EXIT_INTERRUPTED, reported_errors

    out = tmp_path / "out.tif"
    made_then_interrupted = paths.tempfile.mkdtemp

    def mkdtemp(**kwargs: object) -> str:
        made_then_interrupted(**kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(paths.tempfile, "mkdtemp", mkdtemp)
    with pytest.raises(typer.Exit) as stopped, reported_errors(0):
        paths.check_output(out, overwrite=False)
        with paths.staging_folder(out):
            pass
    assert stopped.value.exit_code == EXIT_INTERRUPTED
    assert not list(tmp_path.iterdir())


@pytest.mark.skipif(not LR04.exists(), reason="needs ../shared/data")
def test_a_checkpoint_left_behind_is_continued_or_replaced_never_ignored(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "past.tif"
    common = ["--chronology", LR04, "--from", 0, "--to", 4, "--dt", 1000, "--snapshots", "1"]
    first = run_cli("climate-run", ramp, out, *common, "--max-steps", 2)
    assert first.returncode == 0, first.stderr
    assert (tmp_path / "past_1ka.tif").exists() and not out.exists()
    refused = run_cli("climate-run", ramp, out, *common)
    assert refused.returncode == 2 and "--resume" in refused.stderr and "--overwrite" in refused.stderr
    resumed = run_cli("climate-run", ramp, out, *common, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert out.exists() and not (tmp_path / ".past.tif.checkpoint.npz").exists()


@pytest.mark.parametrize("files, says, never", [
    (["out_001.tif"], "rerun with --overwrite to replace them", "--resume"),
    (["out_001.tif", ".out.tif.checkpoint.npz"], "rerun with --resume to continue where it stopped",
     "--overwrite"),
])
def test_the_interrupt_note_names_resume_where_a_checkpoint_continues_the_run(
        tmp_path: Path, files: list[str], says: str, never: str) -> None:
    """The hint of an interrupted run: --resume where its checkpoint continues it (and not
    --overwrite, which would throw its work away), else --overwrite."""
    from unerode_cli.cli.errors import _written_note
    from unerode_cli.io.paths import OutputPlan

    plan = OutputPlan(resume_flag="--resume", written=[tmp_path / name for name in files])
    note = _written_note(plan)
    assert note.startswith(f"; {len(files)} file(s) had been written and are kept: ")
    assert says in note and never not in note, note
