"""Output plans (refuse clobbering, never write over an input, write atomically) and content
digests of files.

An :class:`OutputPlan` is what one job may write: the outputs it cleared before any work
(:meth:`OutputPlan.check_output`), the inputs it read (never an output, whatever
``--overwrite`` says, also through symlinks and hard links) and the files it has written so
far. Each job runs with its own plan active (:meth:`OutputPlan.active`, a context variable: two
jobs in one process, e.g. ensemble members on threads, never share one); the module functions
below act on the active plan. Every file is written through :func:`atomic_path`: a temporary
file beside the output, named ``.STEM.PID.XXXX.partSUFFIX``, renamed onto the output when
complete. At write time an existing file that the plan neither cleared nor wrote is never
replaced, so a file that escaped the checks is refused rather than clobbered. Temporaries left
by a killed process (whose PID is gone) are removed when the same output is next cleared.
"""

from __future__ import annotations

import contextlib
import contextvars
import hashlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from unerode_cli.errors import InputError


@dataclass
class OutputPlan:
    """The files of one job: inputs read, outputs cleared, files written (in order), files
    removed after a failure, and the job's equivalent command line (for its history)."""

    inputs: list[Path] = field(default_factory=list)
    cleared: set[Path] = field(default_factory=set)
    written: list[Path] = field(default_factory=list)
    removed: list[Path] = field(default_factory=list)
    command_line: list[str] = field(default_factory=list)
    _stale: dict[Path, dict[tuple[str, str], list[Path]]] = field(default_factory=dict, repr=False)

    @contextlib.contextmanager
    def active(self) -> Iterator[OutputPlan]:
        """Make this the plan that :func:`check_output`, :func:`atomic_path` and the writers use."""
        token = _ACTIVE.set(self)
        try:
            yield self
        finally:
            _ACTIVE.reset(token)

    def read(self, path: Path | str) -> None:
        """Record ``path`` as an input: it is never an output of this job."""
        path = Path(path)
        if path not in self.inputs:
            self.inputs.append(path)

    def is_input(self, path: Path, inputs: tuple[Path, ...] = ()) -> Path | None:
        """The input (of the plan or of ``inputs``) that ``path`` names, also through a symlink
        or a hard link; None when it names none."""
        if not path.exists():
            return None
        for src in (*self.inputs, *inputs):
            with contextlib.suppress(OSError):
                if src.exists() and (path.resolve() == src.resolve() or os.path.samefile(path, src)):
                    return src
        return None

    def check_output(self, path: Path, overwrite: bool, inputs: tuple[Path, ...] = ()) -> None:
        """Refuse an output that is an input, exists (without ``overwrite``), is a folder or has
        no folder; once cleared, the output may be written (and replaced) by this job. Stale
        temporaries of earlier, killed writers of this output are removed."""
        if self.is_input(path, inputs) is not None:
            raise InputError(f"output {path} is also an input; inputs are never overwritten.")
        if path.is_dir():
            raise InputError(f"output {path} is a folder, not a file name.")
        if path.exists() and not overwrite:
            raise InputError(f"output {path} already exists; pass --overwrite to replace it.")
        if not path.parent.exists():
            raise InputError(f"the folder of output {path} does not exist.")
        self.cleared.add(path.resolve())
        self.remove_stale_temporaries(path)

    def may_replace(self, path: Path) -> bool:
        """Whether an existing ``path`` was cleared or written by this job."""
        resolved = path.resolve()
        return resolved in self.cleared or resolved in {p.resolve() for p in self.written}

    def discard_written(self) -> list[Path]:
        """Delete every file this job has written (a run that failed keeps nothing); returns
        (and records in ``removed``) the deleted paths."""
        for path in self.written:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
                self.removed.append(path)
        self.written.clear()
        return list(self.removed)

    def remove_stale_temporaries(self, path: Path) -> list[Path]:
        """Delete the temporaries of ``path`` (files, and staging folders of GDAL side files)
        left by writers that no longer run; returns what was deleted. The folder is listed once
        per plan, so clearing many outputs in one folder stays cheap."""
        removed = []
        for candidate in self._stale_temporaries(path.parent).pop((path.stem, path.suffix), []):
            _delete(candidate)
            removed.append(candidate)
        return removed

    def remove_own_temporaries(self) -> list[Path]:
        """Delete the temporaries this process left beside this job's outputs (an interrupt may
        land between a temporary's creation and its clean-up); returns what was deleted."""
        folders = {path.parent for path in self.cleared} | {path.parent for path in self.written}
        removed = []
        for folder in folders:
            for candidate in folder.iterdir() if folder.is_dir() else ():
                match = _TEMPORARY.match(candidate.name)
                if match and int(match["pid"]) == os.getpid():
                    _delete(candidate)
                    removed.append(candidate)
        return removed

    def _stale_temporaries(self, folder: Path) -> dict[tuple[str, str], list[Path]]:
        """(stem, suffix) of an output → temporaries of it in ``folder`` whose writer is gone."""
        key = folder.resolve() if folder.is_dir() else folder
        if key not in self._stale:
            found: dict[tuple[str, str], list[Path]] = {}
            for candidate in folder.iterdir() if folder.is_dir() else ():
                match = _TEMPORARY.match(candidate.name)
                if match and not _running(int(match["pid"])):
                    found.setdefault((match["stem"], match["suffix"] or ""), []).append(candidate)
            self._stale[key] = found
        return self._stale[key]


_ACTIVE: contextvars.ContextVar[OutputPlan | None] = contextvars.ContextVar("output_plan", default=None)


def active_plan() -> OutputPlan:
    """The active output plan; outside any job (a library call), a new plan for this context."""
    plan = _ACTIVE.get()
    if plan is None:
        plan = OutputPlan()
        _ACTIVE.set(plan)
    return plan


def check_output(path: Path, overwrite: bool, inputs: tuple[Path, ...] = ()) -> None:
    """:meth:`OutputPlan.check_output` on the active plan."""
    active_plan().check_output(path, overwrite, inputs)


def written_files() -> list[Path]:
    """The files the active plan has written under their final names, in order."""
    return list(active_plan().written)


def forget_writes() -> None:
    """Start afresh outside any job: a new plan for this context (nothing cleared or written)."""
    _ACTIVE.set(OutputPlan())


def _delete(temporary: Path) -> None:
    """Remove a temporary file or staging folder (gone already is fine)."""
    if temporary.is_dir():
        shutil.rmtree(temporary, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()


_TEMPORARY = re.compile(r"^\.(?P<stem>.+)\.(?P<pid>\d+)\.[^.]+\.part(?P<suffix>\.[^.]*)?(?:\.d)?$")


def _running(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextlib.contextmanager
def staging_folder(path: Path) -> Iterator[Path]:
    """A temporary folder beside ``path`` (named like its temporaries, so that a killed
    writer's folder is cleaned like them), removed with what is left in it afterwards: where a
    writer makes several files (a raster and its side files) before they are placed."""
    folder = Path(tempfile.mkdtemp(prefix=f".{path.stem}.{os.getpid()}.", suffix=f".part{path.suffix}.d",
                                   dir=path.parent or Path(".")))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def place(staged: Path, final: Path) -> None:
    """Rename a finished side file (``.hdr``, ``.prj``, ``.aux.xml``) onto ``final``, recorded
    among the files this process wrote."""
    os.replace(staged, final)
    active_plan().written.append(final)


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    On any exception the temporary file is removed and ``path`` is left untouched, so no
    half-written output ever appears under the final name. An existing ``path`` that this
    job's plan neither cleared nor wrote is never replaced.
    """
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{path.stem}.{os.getpid()}.", suffix=f".part{path.suffix}", dir=path.parent or Path(".")
    )
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        plan = active_plan()
        if path.exists() and not plan.may_replace(path):
            raise InputError(f"output {path} already exists; pass --overwrite to replace it.")
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
        plan.written.append(path)
    finally:
        for leftover in (tmp, Path(f"{tmp}.aux.xml")):
            with contextlib.suppress(FileNotFoundError):
                leftover.unlink()


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def file_sha256(path: Path) -> str:
    """sha256 of a file's bytes (``dir`` for a folder)."""
    if path.is_dir():
        return "dir"
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
