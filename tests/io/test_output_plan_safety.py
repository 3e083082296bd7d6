"""The output plan (issue 45, classes 1, 2, 6 and 7): an input is never an output (through
links too), two outputs never share a file, unwritable or too-long destinations and outputs
bigger than the free space are refused before any work, a new output is placed exclusively (of
two writers only one says it wrote it), a failed write is one sentence, and the leftovers of a
dead writer are removed."""

from __future__ import annotations

import errno
import os
import shutil
import threading
from collections import namedtuple
from pathlib import Path

import pytest
from tests.refusals import read_only_folder

from unerode_cli.errors import InputError, RunFailure, WriteFailure
from unerode_cli.io import paths
from unerode_cli.io.paths import OutputPlan, atomic_path

DEAD_PID = 99999999          # above any pid_max: runs nowhere


def leftovers(folder: Path) -> list[str]:
    """Hidden temporaries of any writer in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if ".part" in p.name)


def write(plan: OutputPlan, path: Path, content: bytes) -> None:
    with plan.active(), atomic_path(path) as tmp:
        tmp.write_bytes(content)


@pytest.fixture
def read_only(tmp_path: Path):
    """A folder this process cannot write (see :func:`tests.refusals.read_only_folder`)."""
    with read_only_folder(tmp_path / "ro") as folder:
        yield folder


# --- class 1: inputs and outputs -----------------------------------------------------------------

@pytest.mark.parametrize("overwrite", [False, True])
@pytest.mark.parametrize("link", ["same", "symlink", "hardlink"])
def test_an_input_is_never_an_output_whatever_overwrite_says(tmp_path: Path, link: str,
                                                              overwrite: bool) -> None:
    source = tmp_path / "k.tif"
    source.write_bytes(b"the K raster")
    output = {"same": source, "symlink": tmp_path / "s.tif", "hardlink": tmp_path / "h.tif"}[link]
    if link == "symlink":
        output.symlink_to(source)
    elif link == "hardlink":
        os.link(source, output)
    plan = OutputPlan()
    plan.read(source)
    with pytest.raises(InputError, match="also an input"):
        plan.check_destinations([(output, False)])
    with pytest.raises(InputError, match="whatever --overwrite says"):
        plan.check_output(output, overwrite)
    assert source.read_bytes() == b"the K raster"
    assert not plan.cleared


def test_two_outputs_on_one_file_are_refused_also_through_links(tmp_path: Path) -> None:
    plan = OutputPlan()
    with pytest.raises(InputError, match="two outputs"):
        plan.check_destinations([(tmp_path / "out.tif", False), (tmp_path / "." / "out.tif", False)])
    existing = tmp_path / "a.tif"
    existing.write_bytes(b"a")
    os.link(existing, tmp_path / "b.tif")
    with pytest.raises(InputError, match="two outputs"):
        plan.check_destinations([(existing, False), (tmp_path / "b.tif", False)])
    (tmp_path / "c.tif").symlink_to(existing)
    with pytest.raises(InputError, match="two outputs"):
        plan.check_destinations([(existing, False), (tmp_path / "c.tif", False)])
    plan.check_output(tmp_path / "d.tif", False)
    with pytest.raises(InputError, match="two outputs"):
        plan.check_output(tmp_path / "d.tif", False)
    plan.check_output(tmp_path / "d.tif", False, again=True)          # the job's own record, again


# --- class 2 and 7: destinations refused at once ----------------------------------------------

def test_an_output_that_is_a_folder_is_said_to_be_a_folder(tmp_path: Path) -> None:
    (tmp_path / "out.tif").mkdir()
    (tmp_path / "outdir").mkdir()
    plan = OutputPlan()
    for path in (tmp_path / "out.tif", tmp_path / "outdir"):
        with pytest.raises(InputError, match="is a folder") as refused:
            plan.check_destinations([(path, False)])
        assert "extension" not in str(refused.value)
        with pytest.raises(InputError, match="is a folder"):
            plan.check_output(path, True)
    plan.check_destinations([(tmp_path / "outdir", True)])               # a folder output: fine


def test_missing_folder_and_a_file_for_a_folder_are_refused(tmp_path: Path) -> None:
    plan = OutputPlan()
    with pytest.raises(InputError, match="does not exist"):
        plan.check_destinations([(tmp_path / "nowhere" / "out.tif", False)])
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="is a file, not a folder"):
        plan.check_destinations([(tmp_path / "file" / "out.tif", False)])
    with pytest.raises(InputError, match="is a file, not a folder"):
        plan.check_destinations([(tmp_path / "file", True)])
    with pytest.raises(InputError, match="does not exist"):
        plan.check_destinations([(tmp_path / "nowhere" / "report", True)])


def test_a_read_only_folder_is_refused(read_only: Path) -> None:
    plan = OutputPlan()
    with pytest.raises(InputError, match="not writable"):
        plan.check_destinations([(read_only / "out.tif", False)])
    with pytest.raises(InputError, match="not writable"):
        plan.check_destinations([(read_only / "report", True)])
    with pytest.raises(InputError, match="not writable"):
        plan.check_destinations([(read_only, True)])
    with pytest.raises(InputError, match="not writable"):
        plan.check_output(read_only / "out.tif", False)
    assert list(read_only.iterdir()) == []


def test_a_name_too_long_once_the_temporary_suffix_is_added_is_refused(tmp_path: Path) -> None:
    name_max = os.pathconf(tmp_path, "PC_NAME_MAX")
    alone = tmp_path / ("n" * (name_max - 10) + ".tif")                  # a valid name by itself
    plan = OutputPlan()
    with pytest.raises(InputError, match="too long"):
        plan.check_destinations([(alone, False)])
    with pytest.raises(InputError, match="too long"):
        plan.check_output(alone, False)
    plan.check_destinations([(tmp_path / ("n" * (name_max - 10)), True)])  # a folder has no temporary
    fits = tmp_path / ("n" * (name_max - paths._TEMPORARY_EXTRA - 4) + ".tif")
    plan.check_output(fits, False)
    with plan.active(), atomic_path(fits) as tmp:
        tmp.write_bytes(b"x")
        Path(f"{tmp}.aux.xml").write_text("<PAMDataset/>")                # GDAL's side file fits too
    assert fits.read_bytes() == b"x"


def test_outputs_bigger_than_the_free_space_are_refused(tmp_path: Path, monkeypatch) -> None:
    source = tmp_path / "in.tif"
    source.write_bytes(b"\0" * 5000)
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda _: usage(10**6, 10**6 - 8000, 8000))
    plan = OutputPlan()
    plan.read(source)
    plan.check_output(tmp_path / "a.tif", False)             # as large as the input: 5000 B
    plan.check_space()
    plan.check_output(tmp_path / "b.tif", False)             # 10 000 B > 8000 B
    with pytest.raises(InputError, match=r"need about 10 kB .* has 8 kB free"):
        plan.check_space()
    small = OutputPlan()
    small.check_output(tmp_path / "t.csv", False, size=7000)
    small.check_space()
    small.expect(tmp_path / "t.csv", 9000)
    with pytest.raises(InputError, match="free"):
        small.check_space()


# --- class 1: two writers of one new file --------------------------------------------------------

@pytest.mark.parametrize("hard_links", [True, False])
def test_of_two_writers_of_one_new_file_only_one_writes_it(tmp_path: Path, monkeypatch,
                                                            hard_links: bool) -> None:
    if not hard_links:                                   # a file system without them (FAT, shares)
        def no_link(*_):
            raise OSError(errno.EPERM, "Operation not permitted")
        monkeypatch.setattr(os, "link", no_link)
    out = tmp_path / "out.tif"
    first, second = OutputPlan(), OutputPlan()
    first.check_output(out, False)
    second.check_output(out, False)                      # both cleared it: it did not exist yet
    write(first, out, b"first")
    with pytest.raises(RunFailure, match="another process wrote") as failed:
        write(second, out, b"second")
    assert "Error" not in str(failed.value)
    assert out.read_bytes() == b"first"
    assert first.written == [out] and second.written == []
    assert leftovers(tmp_path) == []


def test_concurrent_writers_on_threads_give_one_file(tmp_path: Path) -> None:
    out = tmp_path / "out.tif"
    plans = [OutputPlan() for _ in range(4)]
    for plan in plans:
        plan.check_output(out, False)
    start, outcomes = threading.Barrier(len(plans)), []

    def writer(plan: OutputPlan, k: int) -> None:
        start.wait()
        try:
            write(plan, out, f"writer {k}".encode())
            outcomes.append(("wrote", k))
        except RunFailure:
            outcomes.append(("refused", k))

    threads = [threading.Thread(target=writer, args=(plan, k)) for k, plan in enumerate(plans)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    wrote = [k for what, k in outcomes if what == "wrote"]
    assert len(wrote) == 1
    assert out.read_bytes() == f"writer {wrote[0]}".encode()
    assert leftovers(tmp_path) == []


def test_with_overwrite_a_file_is_replaced_and_rewritten(tmp_path: Path) -> None:
    out = tmp_path / "out.tif"
    out.write_bytes(b"old")
    plan = OutputPlan()
    plan.check_output(out, True)
    write(plan, out, b"new")
    write(plan, out, b"newer")                           # a record rewritten as the run goes
    assert out.read_bytes() == b"newer"
    assert plan.written == [out, out] and plan.written_once() == [out]


def test_a_file_that_escaped_the_checks_is_not_replaced(tmp_path: Path) -> None:
    out = tmp_path / "out.tif"
    out.write_bytes(b"precious")
    with pytest.raises(InputError, match="already exists"):
        write(OutputPlan(), out, b"clobber")
    assert out.read_bytes() == b"precious"
    assert leftovers(tmp_path) == []


# --- class 2: a write that fails ------------------------------------------------------------------

@pytest.mark.parametrize(("code", "said"), [(errno.ENOSPC, "is full"), (errno.EACCES, "permission denied")])
def test_a_failed_write_is_one_sentence_and_leaves_no_temporary(tmp_path: Path, code: int, said: str) -> None:
    out = tmp_path / "out.tif"
    plan = OutputPlan()
    plan.check_output(out, False)
    with pytest.raises(WriteFailure, match=said) as failed, plan.active(), atomic_path(out) as tmp:
        tmp.write_bytes(b"half")
        raise OSError(code, os.strerror(code), str(tmp))
    assert "Error" not in str(failed.value) and "Errno" not in str(failed.value)
    assert not out.exists()
    assert leftovers(tmp_path) == []


def test_os_error_reason_names_the_file_without_the_class() -> None:
    assert paths.os_error_reason(OSError(errno.ENAMETOOLONG, "File name too long", "x.tif")) == \
        "x.tif: file name too long"
    assert paths.os_error_reason(OSError(errno.ENOSPC, "No space left on device", "d/x.tif")) == \
        "the file system of d is full"


# --- class 6: leftovers of dead writers; kept-file lists ----------------------------------------

def test_leftovers_of_a_dead_writer_are_removed_when_the_output_is_cleared(tmp_path: Path) -> None:
    dead = [tmp_path / f".out.{DEAD_PID}.k3j2.part.tif", tmp_path / f".out.{DEAD_PID}.k3j2.part.tif.aux.xml",
            tmp_path / f".out.{DEAD_PID}.q7w1.part.tif.d"]
    dead[0].write_bytes(b"half")
    dead[1].write_text("<PAMDataset/>\n")
    dead[2].mkdir()
    (dead[2] / "out.tif").write_bytes(b"half")
    alive = tmp_path / f".out.{os.getpid()}.a1b2.part.tif"          # a writer that still runs
    alive.write_bytes(b"busy")
    other = tmp_path / f".other.{DEAD_PID}.k3j2.part.tif.aux.xml"     # another output's: its own run
    other.write_text("<PAMDataset/>\n")
    OutputPlan().check_output(tmp_path / "out.tif", False)
    assert not any(path.exists() for path in dead)
    assert alive.exists() and other.exists()


def test_a_file_written_many_times_is_discarded_and_listed_once(tmp_path: Path) -> None:
    out, record = tmp_path / "out.tif", tmp_path / ".out.tif.checkpoint.npz"
    plan = OutputPlan()
    plan.check_output(out, False)
    plan.check_output(record, False)
    for k in range(5):
        write(plan, record, bytes([k]))
    write(plan, out, b"x")
    assert plan.written_once() == [record, out]
    assert plan.discard_written() == [record, out]
    assert not out.exists() and not record.exists()
