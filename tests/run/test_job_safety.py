"""What :func:`~unerode_cli.run.job.execute` and the command line guarantee of every job's files
(issue 45, classes 1, 2, 6 and 7): every file a job reads (parameter rasters and tables given
as text, rasters a parameter file names) is never one of its outputs, two outputs never share a
file, unwritable destinations are refused before any work, of two concurrent writers of one new
file only one says "wrote", a failed write keeps and lists what was complete, the Ctrl-C list
names each file once with the right rerun hint, and no message shows a Python class name."""

from __future__ import annotations

import errno
import os
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import typer
from tests.conftest import write_geotiff
from tests.refusals import CLASS_NAME, cli, read_only_folder, snapshot
from typer.testing import CliRunner

from unerode_cli.cli.app import app
from unerode_cli.cli.errors import reported_errors
from unerode_cli.errors import InputError, RunFailure, WriteFailure
from unerode_cli.io.paths import OutputPlan, atomic_path
from unerode_cli.run.declare import Opt, declared, read_files
from unerode_cli.run.job import Job, Progress, execute

DEAD_PID = 99999999          # above any pid_max: runs nowhere


def assert_one_sentence(stderr: str, phrase: str) -> None:
    import re

    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1, stderr
    assert lines[0].startswith("error: ") and lines[0].rstrip().endswith("."), stderr
    assert not re.search(CLASS_NAME, stderr), stderr
    assert phrase.lower() in lines[0].lower(), stderr


def assert_refused(folder: Path, args: tuple[object, ...], phrase: str, *, seconds: float = 10.0) -> None:
    """The command exits 2 with one sentence containing ``phrase``, at once, and leaves every
    file as it was (no new file, no temporary)."""
    before = snapshot(folder)
    start = time.perf_counter()
    code, stderr = cli(folder, *args)
    assert code == 2, stderr
    assert time.perf_counter() - start < seconds
    assert_one_sentence(stderr, phrase)
    assert snapshot(folder) == before


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """A folder with a DEM (in.tif) and a constant K raster (k.tif) on its grid."""
    rows, cols = np.indices((24, 20))
    write_geotiff(tmp_path / "in.tif", (10.0 + 2.0 * (23 - rows) + 0.5 * np.sin(cols)).astype(np.float32))
    write_geotiff(tmp_path / "k.tif", np.full((24, 20), 1e-5, np.float32))
    return tmp_path


@pytest.fixture
def read_only(folder: Path):
    """``folder/ro``, which this process cannot write (see :func:`tests.refusals.read_only_folder`)."""
    with read_only_folder(folder / "ro") as path:
        yield path


# --- class 1: what a command reads is never one of its outputs -------------------------------

def test_a_parameter_raster_is_never_the_output_whatever_overwrite_says(folder: Path) -> None:
    assert_refused(folder, ("erode", "in.tif", "k.tif", "--K", "k.tif", "--steps", "2", "--overwrite"),
                   "also an input")


def test_a_parameter_raster_is_recognised_through_a_hard_link_and_a_symlink(folder: Path) -> None:
    os.link(folder / "k.tif", folder / "hard.tif")
    (folder / "soft.tif").symlink_to("k.tif")
    for output in ("hard.tif", "soft.tif"):
        assert_refused(folder, ("erode", "in.tif", output, "--K", "k.tif", "--steps", "2", "--overwrite"),
                       "also an input")


def test_a_raster_named_by_a_parameter_file_is_never_the_output(folder: Path) -> None:
    (folder / "p.yaml").write_text("K: k.tif\n")
    assert_refused(folder, ("erode", "in.tif", "k.tif", "--params", "p.yaml", "--steps", "2", "--overwrite"),
                   "also an input")


def test_a_table_read_twice_is_never_an_output(folder: Path) -> None:
    (folder / "e.csv").write_text("time,ela\n0,150\n1000,150\n")
    assert_refused(folder, ("glaciate", "in.tif", "out.tif", "--ela", "e.csv", "--timeline", "e.csv",
                            "--duration", "20", "--overwrite"), "also an input")


@pytest.mark.parametrize("args", [
    ("erode", "in.tif", "out.tif", "--change-map", "out.tif", "--steps", "2"),
    ("hypsometry", "in.tif", "--csv", "h.png", "--plot", "h.png"),
])
def test_two_outputs_of_one_command_on_one_file_are_refused_before_any_work(folder: Path, args) -> None:
    assert_refused(folder, args, "two outputs")


def test_read_files_names_parameter_rasters_and_the_rasters_of_a_parameter_file(folder: Path) -> None:
    from unerode_cli.jobs.erode.job import ErosionJob

    write_geotiff(folder / "kd.tif", np.full((24, 20), 0.01, np.float32))
    (folder / "p.yaml").write_text("m: 0.5\nthermal:\n  k_th: kd.tif\n")
    job = ErosionJob(source=folder / "in.tif", output=folder / "out.tif", k=str(folder / "k.tif"),
                     params=folder / "p.yaml", steps=2)
    read = {path.resolve() for path in read_files(job)}
    assert {folder / "in.tif", folder / "k.tif", folder / "p.yaml", folder / "kd.tif"} <= read
    assert folder / "out.tif" not in read


# --- class 2 and 7: destinations refused before any work --------------------------------------

@pytest.mark.parametrize(("args", "phrase"), [
    (("erode", "in.tif", "ro/out.tif", "--steps", "2"), "not writable"),
    (("landforms", "in.tif", "--out", "ro/lf"), "not writable"),
    (("compare-terraces", "--present", "in.tif", "--snapshots", "in.tif", "--auto-river", "--out", "ro/rep"),
     "not writable"),
])
def test_a_read_only_folder_is_refused_at_once(folder: Path, read_only: Path, args, phrase: str) -> None:
    assert_refused(folder, args, phrase)


@pytest.mark.parametrize(("args", "phrase"), [
    (("erode", "in.tif", "nowhere/out.tif", "--steps", "2"), "does not exist"),
    (("erode", "in.tif", "k.tif/out.tif", "--steps", "2"), "not a folder"),
    (("erode", "in.tif", "n" * 246 + ".tif", "--steps", "2"), "too long"),
    (("erode", "in.tif", "out.tif", "--steps", "2", "--change-map", "n" * 246 + ".tif"), "too long"),
])
def test_an_impossible_destination_is_refused_at_once(folder: Path, args, phrase: str) -> None:
    assert_refused(folder, args, phrase)


@pytest.mark.parametrize("args", [
    ("convert", "in.tif", "out.tif"),
    ("convert", "in.tif", "outdir"),
    ("hypsometry", "in.tif", "--plot", "out.tif"),
    ("sandstone", "arch", "sand", "--mesh", "out.tif"),
])
def test_an_output_that_is_a_folder_is_called_a_folder(folder: Path, args) -> None:
    (folder / "out.tif").mkdir()
    (folder / "outdir").mkdir()
    before = snapshot(folder)
    code, stderr = cli(folder, *args)
    assert code == 2, stderr
    assert_one_sentence(stderr, "is a folder")
    assert "extension" not in stderr
    assert snapshot(folder) == before


# --- class 1: two writers of one new file -------------------------------------------------------

@declared("two-writers", [Opt("output", Path, argument=True, required=True, role="output", record=False),
                          Opt("text", str, "x", record=False),
                          Opt("overwrite", bool, False, kind="flag", record=False)])
class WriterJob(Job):
    """A job that clears OUTPUT, waits at ``barrier`` in its run and writes ``text`` into it."""

    barrier = None

    def plan(self, outputs: OutputPlan) -> Any:
        outputs.check_output(self.output, self.overwrite)
        return self.text

    def run(self, planned: Any, progress: Progress) -> Any:
        if self.barrier is not None:
            self.barrier.wait()
        return planned

    def write(self, result: Any, outputs: OutputPlan) -> str:
        with atomic_path(self.output) as tmp:
            tmp.write_text(result)
        return f"wrote {self.output}"


def test_of_two_concurrent_writers_of_a_new_file_only_one_says_wrote(tmp_path: Path, monkeypatch) -> None:
    out = tmp_path / "out.txt"
    monkeypatch.setattr(WriterJob, "barrier", threading.Barrier(2))
    said: dict[str, str] = {}

    def writer(text: str) -> None:
        try:
            said[text] = execute(WriterJob(output=out, text=text))
        except RunFailure as exc:
            said[text] = f"failed: {exc}"

    threads = [threading.Thread(target=writer, args=(text,)) for text in ("first", "second")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    wrote = [text for text, summary in said.items() if summary.startswith("wrote")]
    assert len(wrote) == 1, said
    loser = next(summary for text, summary in said.items() if text not in wrote)
    assert "another process wrote" in loser
    assert out.read_text() == wrote[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_an_output_written_meanwhile_by_another_process_is_exit_1(tmp_path: Path) -> None:
    out = tmp_path / "out.txt"

    class Meanwhile(WriterJob):
        def run(self, planned: Any, progress: Progress) -> Any:
            out.write_text("the other process's result")
            return planned

    with pytest.raises(typer.Exit) as ended, reported_errors(0) as plan:
        execute(Meanwhile(output=out, text="mine"), outputs=plan)
    assert ended.value.exit_code == 1
    assert out.read_text() == "the other process's result"


# --- class 2: a write that fails, and the last catch-all ---------------------------------------

@declared("fills-the-disk", [Opt("folder", Path, argument=True, required=True, record=False)])
class FullDiskJob(Job):
    """Writes a.txt, then fails to write b.txt: the file system is full."""

    def plan(self, outputs: OutputPlan) -> Any:
        for name in ("a.txt", "b.txt"):
            outputs.check_output(self.folder / name, False)

    def write(self, result: Any, outputs: OutputPlan) -> str:
        with atomic_path(self.folder / "a.txt") as tmp:
            tmp.write_text("complete")
        with open(self.folder / "b.txt.log", "w") as f:     # a write that is not through the plan
            f.close()
            raise OSError(errno.ENOSPC, "No space left on device", str(self.folder / "b.txt"))


def test_a_full_disk_is_one_sentence_exit_1_listing_the_files_kept(tmp_path: Path, capsys) -> None:
    with pytest.raises(WriteFailure, match="is full"):
        execute(FullDiskJob(folder=tmp_path))
    assert (tmp_path / "a.txt").read_text() == "complete"
    (tmp_path / "a.txt").unlink()
    (tmp_path / "b.txt.log").unlink()
    with pytest.raises(typer.Exit) as ended, reported_errors(0) as plan:
        execute(FullDiskJob(folder=tmp_path), outputs=plan)
    assert ended.value.exit_code == 1
    stderr = capsys.readouterr().err
    assert_one_sentence(stderr, "is full")
    assert "kept" in stderr and str(tmp_path / "a.txt") in stderr
    assert (tmp_path / "a.txt").exists() and not (tmp_path / "b.txt").exists()
    assert not list(tmp_path.glob(".*part*"))


@pytest.mark.parametrize("exc", [
    ValueError("numpy.linalg.LinAlgError: Singular matrix"),
    KeyError("unerode"),
    OSError(errno.ENAMETOOLONG, "File name too long", ".x.tif.checkpoint.npz"),
    RuntimeError("CPLE_AppDefinedError: TIFFWriteDirectory failed"),
    SystemError("<built-in function step> returned NULL without setting an exception"),
])
def test_no_message_shows_a_python_class_name(exc: Exception, capsys) -> None:
    with pytest.raises(typer.Exit) as ended, reported_errors(0):
        raise exc
    assert ended.value.exit_code == 1
    stderr = capsys.readouterr().err
    assert_one_sentence(stderr, "the run failed unexpectedly")


def test_an_input_error_quoting_a_class_name_is_said_without_it(capsys) -> None:
    with pytest.raises(typer.Exit) as ended, reported_errors(0):
        raise InputError("the header of x.exr is malformed (JSONDecodeError: Expecting value).")
    assert ended.value.exit_code == 2
    assert_one_sentence(capsys.readouterr().err, "malformed")


# --- class 6: clean-up and the kept-file list on Ctrl-C ----------------------------------------

@pytest.mark.parametrize(("flag", "name", "hint", "not_hint"), [
    ("--resume", ".out.tif.checkpoint.npz", "--resume", "--overwrite"),     # climate-run, erode
    ("--resume", "state.npz", "--resume", "--overwrite"),                   # sandstone
    ("--resume", "out_001.tif", "--overwrite", "--resume"),                 # no checkpoint yet
    ("", ".out.tif.checkpoint.npz", "--overwrite", "--resume"),             # no --resume
])
def test_ctrl_c_lists_each_kept_file_once_with_the_command_s_rerun_hint(
        tmp_path: Path, capsys, flag: str, name: str, hint: str, not_hint: str) -> None:
    record = tmp_path / name
    with pytest.raises(typer.Exit) as ended, reported_errors(0) as plan:
        plan.resume_flag = flag
        plan.check_output(record, False)
        for k in range(42):
            with atomic_path(record) as tmp:
                tmp.write_bytes(bytes([k]))
        raise KeyboardInterrupt
    assert ended.value.exit_code == 130
    stderr = capsys.readouterr().err
    assert stderr.count(str(record)) == 1, stderr
    assert "1 file(s)" in stderr and hint in stderr and not_hint not in stderr
    assert not list(tmp_path.glob(".*part*"))


def test_an_ensemble_resumes_from_its_finished_members(tmp_path: Path, capsys) -> None:
    member = tmp_path / "m0.tif"
    with pytest.raises(typer.Exit), reported_errors(0) as plan:
        plan.resume_flag, plan.resumes_from_outputs = "--resume", True
        plan.check_output(member, False)
        with atomic_path(member) as tmp:
            tmp.write_bytes(b"member 0")
        raise KeyboardInterrupt
    stderr = capsys.readouterr().err
    assert "--resume" in stderr and "--overwrite" not in stderr


def test_resume_is_the_hint_of_the_commands_that_have_it() -> None:
    from unerode_cli.run.declare import resume_flag

    for command, expected in (("climate-run", "--resume"), ("erode", "--resume"), ("convert", "")):
        from unerode_cli.pipeline.commands import JOBS

        assert resume_flag(JOBS[command].job_class()) == expected


def test_the_next_run_removes_the_leftovers_of_a_dead_writer(folder: Path) -> None:
    dead = [folder / f".out.{DEAD_PID}.k3j2.part.tif.aux.xml", folder / f".out.{DEAD_PID}.q7w1.part.tif.d"]
    dead[0].write_text("<PAMDataset/>\n")
    dead[1].mkdir()
    (dead[1] / "out.tif").write_bytes(b"half-written")
    code, stderr = cli(folder, "convert", "in.tif", "out.tif")
    assert code == 0, stderr
    assert not any(path.exists() for path in dead)
    assert (folder / "out.tif").exists()


# --- class 7: -v and -q are counters ---------------------------------------------------------------

@pytest.mark.parametrize("command", [("erode",), ("convert",), ("pipeline", "run")])
def test_verbose_and_quiet_are_shown_as_counters(command: tuple[str, ...]) -> None:
    runner = CliRunner()
    result = runner.invoke(app, [*command, "--help"], env={"COLUMNS": "160"})
    assert result.exit_code == 0
    lines = [line for line in result.output.splitlines() if "--verbose" in line or "--quiet" in line]
    assert len(lines) == 2, result.output
    for line in lines:
        assert "<int>" not in line.lower() and "integer" not in line.lower(), line
    assert "-vv" in result.output


def test_a_python_warning_is_shown_without_its_class(capsys) -> None:
    import warnings

    with reported_errors(0):
        warnings.warn("invalid value encountered in divide", RuntimeWarning, stacklevel=1)
    stderr = capsys.readouterr().err
    assert stderr == "warning: invalid value encountered in divide.\n"


def test_a_ctrl_c_said_as_another_error_inside_a_kernel_call_is_an_interrupt(tmp_path: Path) -> None:
    """numba's dispatcher reports a SIGINT that lands in its C code as a SystemError caused by
    the KeyboardInterrupt: any job's executor raises it as the interrupt (exit 130 on the
    command line), and no output or temporary is left."""

    class InterruptedInKernel(WriterJob):
        def run(self, planned: Any, progress: Progress) -> Any:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as inner:
                raise SystemError("CPUDispatcher(<function kernel>) returned a result with an "
                                  "exception set") from inner

    with pytest.raises(typer.Exit) as ended, reported_errors(0) as plan:
        execute(InterruptedInKernel(output=tmp_path / "out.txt"), outputs=plan)
    assert ended.value.exit_code == 130
    assert list(tmp_path.iterdir()) == []
