"""Output plans (refuse clobbering, never write over an input, write atomically) and content
digests of files.

An :class:`OutputPlan` is what one job may write: the outputs it cleared before any work
(:meth:`OutputPlan.check_output`), the inputs it read (never an output, whatever
``--overwrite`` says, also through symlinks and hard links), the bytes it expects to write
(checked against the free space of each file system, :meth:`OutputPlan.check_space`) and the
files it has written so far. Each job runs with its own plan active (:meth:`OutputPlan.active`,
a context variable: two jobs in one process, e.g. ensemble members on threads, never share
one); the module functions below act on the active plan.

Every file is written through :func:`atomic_path`: a temporary file beside the output, named
``.STEM.PID.TOKENXXXXXXXX.partSUFFIX`` (TOKEN: the plan's, e.g. ``1a-``), put in place when
complete. An output that did not exist when it was cleared without ``--overwrite`` is put in
place exclusively (a hard link that fails when the name exists), so that of two processes
writing the same new file only one succeeds; the other fails with
:class:`~unerode_cli.errors.RunFailure`. At write time an existing file that the plan neither
cleared nor wrote is never replaced, so a file that escaped the checks is refused rather than
clobbered. An OSError of a write (a full disk) is a :class:`~unerode_cli.errors.WriteFailure`.
Temporaries left by a killed process (whose PID is gone) — the file, GDAL's ``.aux.xml``
beside it and staging folders (``….partSUFFIX.d``) — are removed when the same output is next
cleared; those of a plan that ends, by the plan (:meth:`OutputPlan.remove_own_temporaries`).
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import hashlib
import itertools
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from unerode_cli.errors import InputError, RunFailure, WriteFailure

#: Extensions of raster outputs whose size, when a job does not state it, is taken as that of
#: the largest raster input (same grid; see :meth:`OutputPlan.check_space`).
RASTER_SUFFIXES = frozenset({".tif", ".tiff", ".exr", ".asc", ".bil", ".img", ".gpkg", ".nc", ".vrt",
                             ".flt", ".hgt", ".bt", ".ter", ".xyz"})

#: Characters a temporary adds to the output's stem (``.`` + PID of up to 7 digits + ``.`` + the
#: plan's token of up to 6 characters + 8 random characters + ``.part``), and the longest ending
#: after the suffix (GDAL's ``.aux.xml``).
_TEMPORARY_EXTRA = (len(".") + len(".9999999") + len(".") + len("fffff-") + len("XXXXXXXX") + len(".part")
                    + len(".aux.xml"))

#: Endings of the names of checkpoints (``io.checkpoints``: ``.OUT.checkpoint.npz`` beside an
#: output, ``state.npz`` in a run folder).
CHECKPOINT_ENDINGS = (".checkpoint.npz", "state.npz")

#: Numbers of the plans of this process (each plan's temporaries carry its own, see
#: :attr:`OutputPlan.token`).
_PLAN_NUMBERS = itertools.count(1)


@dataclass
class OutputPlan:
    """The files of one job: inputs read, outputs cleared (with the bytes expected of some),
    files written (in order; a file rewritten is listed at each write), files removed after a
    failure, the job's equivalent command line (for its history) and the flag that continues
    an interrupted run of it (``--resume``; '' for a job that cannot be continued), which
    continues from a checkpoint (:meth:`can_resume`) or, where ``resumes_from_outputs`` says so
    (an ensemble's finished members), from the files written."""

    inputs: list[Path] = field(default_factory=list)
    #: The virtual raster (.vrt) input that reads each of its source files listed in ``inputs``.
    read_by: dict[Path, Path] = field(default_factory=dict)
    cleared: set[Path] = field(default_factory=set)
    written: list[Path] = field(default_factory=list)
    removed: list[Path] = field(default_factory=list)
    command_line: list[str] = field(default_factory=list)
    resume_flag: str = ""
    resumes_from_outputs: bool = False
    expected: dict[Path, int] = field(default_factory=dict)
    _exclusive: set[Path] = field(default_factory=set, repr=False)
    _identities: set[tuple[int, int]] = field(default_factory=set, repr=False)
    _stale: dict[Path, dict[tuple[str, str], list[Path]]] = field(default_factory=dict, repr=False)
    token: str = field(default_factory=lambda: f"{next(_PLAN_NUMBERS) % 0x100000:x}-", repr=False)

    @contextlib.contextmanager
    def active(self) -> Iterator[OutputPlan]:
        """Make this the plan that :func:`check_output`, :func:`atomic_path` and the writers use."""
        token = _ACTIVE.set(self)
        try:
            yield self
        finally:
            _ACTIVE.reset(token)

    def read(self, path: Path | str) -> None:
        """Record ``path`` as an input: it is never an output of this job; nor, for a GDAL
        virtual raster (``.vrt``), is any of the files it reads."""
        path = Path(path)
        if path in self.inputs:
            return
        self.inputs.append(path)
        for source in _vrt_sources(path):
            if source not in self.inputs:
                self.inputs.append(source)
                self.read_by[source] = path

    def is_input(self, path: Path, inputs: tuple[Path, ...] = ()) -> Path | None:
        """The input (of the plan or of ``inputs``) that ``path`` names, also through a symlink
        or a hard link; None when it names none."""
        if not _exists(path):
            return None
        for src in (*self.inputs, *inputs):
            with contextlib.suppress(OSError, ValueError):
                if src.exists() and (path.resolve() == src.resolve() or os.path.samefile(path, src)):
                    return src
        return None

    def check_destinations(self, outputs: Iterable[tuple[Path, bool]]) -> None:
        """Before a job plans: refuse (InputError) what no output may be, for each output
        ``(path, is_folder)`` its options name — see :meth:`check_destination` — and two of
        them naming one file or folder (also through a symlink or a hard link). A file directly
        in an output folder that does not exist yet (``--mesh OUT_DIR/rock.obj``) is left to
        the job, which creates the folder and clears the file (:meth:`check_output`)."""
        outputs = [(Path(path), folder) for path, folder in outputs]
        created = {_resolved(path) for path, folder in outputs if folder and not _exists(path)}
        seen: dict[object, Path] = {}
        for path, folder in outputs:
            if folder or _resolved(path.parent) not in created:
                self.check_destination(path, folder)
            key = _identity(path) or _resolved(path)
            if key in seen:
                same = "" if seen[key] == path else f" (as {seen[key]} and as {path})"
                raise InputError(f"{path} is given for two outputs of this command{same}; give each "
                                 "output its own name.")
            seen[key] = path

    def check_destination(self, path: Path, folder: bool = False) -> None:
        """Refuse (InputError) an output of this job (a file, or with ``folder`` a folder the
        job fills) that is one of the plan's inputs; a file that is a folder; a folder that is
        a file or cannot be written; a name too long for its file system (for a file, once a
        temporary's additions are made); a missing, non-folder or read-only folder above it."""
        path = Path(path)
        source = self.is_input(path)
        if source is not None:
            raise _input_output(path, source, self.read_by.get(source))
        if folder:
            if path.is_dir():
                if not os.access(path, os.W_OK | os.X_OK):
                    raise InputError(f"the output folder {path} is not writable; choose another folder "
                                     "or change its permissions.")
                return
            if _exists(path):
                raise InputError(f"the output folder {path} is a file, not a folder.")
            _check_folder(path, extra=0)
            return
        _check_folder(path)
        if path.is_dir():
            raise _is_a_folder(path)

    def check_output(self, path: Path, overwrite: bool, inputs: tuple[Path, ...] = (), *,
                     size: int | None = None, again: bool = False) -> None:
        """Clear ``path`` as an output of this job; once cleared it may be written (and
        rewritten) by this job. Refused (InputError): a name too long for its folder once a
        temporary's additions are made, a folder that is missing, not a folder or not
        writable, an input (whatever ``overwrite`` says), a folder, an existing file without
        ``overwrite``, and a path this plan has already cleared — two outputs of one command
        on one file — unless ``again`` says that the job clears its own file once more (a
        record rewritten as the run goes). ``size``: bytes the job expects to write there.
        Stale temporaries of earlier, killed writers of this output are removed."""
        path = Path(path)
        _check_folder(path)
        source = self.is_input(path, inputs)
        if source is not None:
            raise _input_output(path, source, self.read_by.get(source))
        if path.is_dir():
            raise _is_a_folder(path)
        resolved = _resolved(path)
        if self._cleared_already(path, resolved):
            if not again:
                raise InputError(f"{path} is given for two outputs of this command; give each output "
                                 "its own file name.")
        elif path.exists() and not overwrite:
            raise InputError(f"output {path} already exists; pass --overwrite to replace it.")
        if size is not None:
            self.expect(path, size)
        if resolved in self.cleared:
            return
        self.cleared.add(resolved)
        identity = _identity(path)
        if identity is not None:
            self._identities.add(identity)
        elif not overwrite:
            self._exclusive.add(resolved)
        self.remove_stale_temporaries(path)

    def expect(self, path: Path, nbytes: int) -> None:
        """State that about ``nbytes`` bytes will be written to the output ``path`` (checked
        against the free space of its file system by :meth:`check_space`)."""
        self.expected[_resolved(Path(path))] = max(0, int(nbytes))

    def check_space(self) -> None:
        """Refuse (InputError) outputs that do not fit in the free space of their file system:
        the bytes stated by :meth:`expect` (a raster output without a stated size counts as
        large as the largest raster input), summed per file system. A file replaced counts in
        full: its temporary is written before the old file goes."""
        default = max((_size(p) for p in self.inputs if p.suffix.lower() in RASTER_SUFFIXES), default=0)
        need: dict[int, tuple[Path, int]] = {}
        for path in self.cleared:
            nbytes = self.expected.get(path)
            if nbytes is None:
                nbytes = default if path.suffix.lower() in RASTER_SUFFIXES else 0
            with contextlib.suppress(OSError):
                device = os.stat(path.parent).st_dev
                folder, total = need.get(device, (path.parent, 0))
                need[device] = (folder, total + nbytes)
        for folder, total in need.values():
            try:
                free = shutil.disk_usage(folder).free
            except OSError:
                continue
            if total > free:
                raise InputError(f"the outputs need about {_bytes(total)} but the file system of {folder} "
                                 f"has {_bytes(free)} free; free some space or write the outputs elsewhere.")

    def may_replace(self, path: Path) -> bool:
        """Whether an existing ``path`` was cleared or written by this job."""
        resolved = _resolved(path)
        return resolved in self.cleared or resolved in {_resolved(p) for p in self.written}

    def put_in_place(self, temporary: Path, final: Path) -> None:
        """Move a finished ``temporary`` onto ``final`` and record it as written. A new file (one
        that did not exist when cleared without ``--overwrite``, or was never cleared) is put
        there exclusively: RunFailure when another process created it meanwhile."""
        if self._must_create(final):
            _create_exclusively(temporary, final)
            self._exclusive.discard(_resolved(final))
        else:
            os.replace(temporary, final)
        self.written.append(final)

    def can_resume(self) -> bool:
        """Whether an interrupted run of this job can be continued with :attr:`resume_flag`:
        the job has one, and it has written a checkpoint (``.OUT.checkpoint.npz``, or the
        ``state.npz`` of a run folder) or continues from whatever it wrote."""
        if not self.resume_flag or not self.written:
            return False
        return self.resumes_from_outputs or any(p.name.endswith(CHECKPOINT_ENDINGS) for p in self.written)

    def written_once(self) -> list[Path]:
        """The files written, each once (in the order of their first write)."""
        return list(dict.fromkeys(self.written))

    def discard_written(self) -> list[Path]:
        """Delete every file this job has written (a run that failed keeps nothing); returns
        (and records in ``removed``) the deleted paths, each once."""
        for path in self.written_once():
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
                self.removed.append(path)
        self.written.clear()
        return list(dict.fromkeys(self.removed))

    def remove_stale_temporaries(self, path: Path) -> list[Path]:
        """Delete the temporaries of ``path`` (files, GDAL's side files of them and staging
        folders) left by writers that no longer run; returns what was deleted. The folder is
        listed once per plan, so clearing many outputs in one folder stays cheap."""
        removed = []
        for candidate in self._stale_temporaries(path.parent).pop((path.stem, path.suffix), []):
            _delete(candidate)
            removed.append(candidate)
        return removed

    def remove_own_temporaries(self) -> list[Path]:
        """Delete the temporaries this plan left beside its job's outputs (an interrupt may land
        between a temporary's creation and its clean-up), recognised by this process's PID and
        the plan's :attr:`token`, so that the temporaries of another job running meanwhile in
        this process (an ensemble member on another thread) are left alone; returns what was
        deleted."""
        folders = {path.parent for path in self.cleared} | {path.parent for path in self.written}
        removed = []
        for folder in folders:
            for candidate in folder.iterdir() if folder.is_dir() else ():
                match = _TEMPORARY.match(candidate.name)
                if match and int(match["pid"]) == os.getpid() and match["random"].startswith(self.token):
                    _delete(candidate)
                    removed.append(candidate)
        return removed

    def _cleared_already(self, path: Path, resolved: Path) -> bool:
        """Whether ``path`` (or a file it is a hard link of) was cleared by this plan."""
        if resolved in self.cleared:
            return True
        identity = _identity(path)
        return identity is not None and identity in self._identities

    def _must_create(self, final: Path) -> bool:
        """Whether ``final`` is a new file of this job, to be created exclusively: cleared
        without ``--overwrite`` when it did not exist and not yet written, or not cleared at all
        (a side file such as ``.aux.xml``) while no output it belongs to was cleared with
        ``--overwrite``."""
        resolved = _resolved(final)
        if resolved in self._exclusive:
            return True
        if resolved in self.cleared or resolved in {_resolved(p) for p in self.written}:
            return False
        owners = [c for c in self.cleared
                  if c.parent == resolved.parent and final.name.startswith(f"{c.stem}.")]
        return not owners or all(owner in self._exclusive for owner in owners)

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


def _vrt_sources(path: Path) -> list[Path]:
    """The files a GDAL virtual raster (``.vrt``) reads, nested VRTs included, as GDAL lists
    them; [] for another file or a VRT GDAL cannot open (refused where it is read)."""
    if path.suffix.lower() != ".vrt" or not path.is_file():
        return []
    import rasterio

    try:
        with rasterio.open(path) as src:
            return [Path(name) for name in src.files if Path(name) != path]
    except (rasterio.errors.RasterioError, OSError):
        return []


def check_output(path: Path, overwrite: bool, inputs: tuple[Path, ...] = (), *,
                 size: int | None = None, again: bool = False) -> None:
    """:meth:`OutputPlan.check_output` on the active plan."""
    active_plan().check_output(path, overwrite, inputs, size=size, again=again)


def expect(path: Path, nbytes: int) -> None:
    """:meth:`OutputPlan.expect` on the active plan."""
    active_plan().expect(path, nbytes)


def written_files() -> list[Path]:
    """The files the active plan has written under their final names, in order."""
    return list(active_plan().written)


def forget_writes() -> None:
    """Start afresh outside any job: a new plan for this context (nothing cleared or written)."""
    _ACTIVE.set(OutputPlan())


def _input_output(path: Path, source: Path, vrt: Path | None = None) -> InputError:
    """The refusal of an output ``path`` that is the input ``source`` (a file the virtual
    raster ``vrt`` reads)."""
    same = "" if source == path else f" (it is {source} through a link)"
    if vrt is not None:
        same += f" (read by {vrt})"
    return InputError(f"output {path} is also an input of this command{same}; inputs are never "
                      "overwritten, whatever --overwrite says, so give the output another name.")


def _is_a_folder(path: Path) -> InputError:
    """The refusal of a file output ``path`` that is an existing folder."""
    return InputError(f"output {path} is a folder, not a file name; give a file name inside it.")


def _check_folder(path: Path, extra: int = _TEMPORARY_EXTRA) -> None:
    """Refuse (InputError) an output whose name, with ``extra`` bytes more (a temporary's
    additions), is too long for its folder's file system, or whose folder is missing, not a
    folder or not writable."""
    folder = path.parent
    try:
        name_max = os.pathconf(folder if folder.is_dir() else ".", "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    longest = len(os.fsencode(path.name)) + extra
    if longest > name_max:
        hidden = f", {extra} of them for the hidden temporary's additions" if extra else ""
        raise InputError(f"the name of output {path.name[:40]}… ({len(os.fsencode(path.name))} bytes) is too "
                         f"long for its folder's file system, which takes names of up to {name_max} bytes"
                         f"{hidden}; choose a shorter name.")
    if not folder.exists():
        raise InputError(f"the folder {folder} of output {path.name} does not exist; create it first.")
    if not folder.is_dir():
        raise InputError(f"{folder}, the folder of output {path.name}, is a file, not a folder.")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"the folder {folder} of output {path.name} is not writable; choose another "
                         "folder or change its permissions.")


def _exists(path: Path) -> bool:
    """Whether ``path`` exists (False where it cannot even be looked at)."""
    try:
        return path.exists()
    except (OSError, ValueError):
        return False


def _resolved(path: Path) -> Path:
    """``path`` with symlinks resolved (as far as they exist)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return path.absolute()


def _identity(path: Path) -> tuple[int, int] | None:
    """(device, inode) of an existing file, None when there is none."""
    try:
        info = path.stat()
    except (OSError, ValueError):
        return None
    return (info.st_dev, info.st_ino)


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except (OSError, ValueError):
        return 0


def _bytes(nbytes: float) -> str:
    """``nbytes`` for people: ``512 B``, ``3.2 MB``, ``1.5 GB``."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if nbytes < 1000 or unit == "TB":
            return f"{nbytes:.0f} {unit}" if unit == "B" else f"{nbytes:.3g} {unit}"
        nbytes /= 1000
    return f"{nbytes:.3g} TB"


def _delete(temporary: Path) -> None:
    """Remove a temporary file or staging folder (gone already is fine)."""
    if temporary.is_dir():
        shutil.rmtree(temporary, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()


#: A temporary of an output STEM.SUFFIX: ``.STEM.PID.RANDOM.partSUFFIX`` (RANDOM: the writing plan's
#: token and random characters), GDAL's side file of it (``….partSUFFIX.aux.xml``) or a staging
#: folder (``….partSUFFIX.d``).
_TEMPORARY = re.compile(
    r"^\.(?P<stem>.+)\.(?P<pid>\d+)\.(?P<random>[^.]+)\.part(?P<suffix>\.[^.]*)?(?:\.d|\.aux\.xml)?$")


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


def _create_exclusively(temporary: Path, final: Path) -> None:
    """Give the finished ``temporary`` the name ``final``, which must not exist: a hard link
    (where the file system has none, an exclusive placeholder replaced at once), then the
    temporary's name is removed. RunFailure when ``final`` exists by now."""
    try:
        try:
            os.link(temporary, final)
        except FileExistsError:
            raise
        except OSError:                                   # no hard links here (FAT, some shares)
            os.close(os.open(final, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
            os.replace(temporary, final)
            return
    except FileExistsError:
        raise RunFailure(f"another process wrote {final} meanwhile; that file is left as it is "
                         "(pass --overwrite to replace it)") from None
    with contextlib.suppress(FileNotFoundError):
        temporary.unlink()


def os_error_reason(exc: OSError) -> str:
    """What an OSError says, in words and without its class: ``the file system of out is full``,
    ``out/x.tif: permission denied``."""
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        where = f" of {Path(exc.filename).parent}" if isinstance(exc.filename, str | Path) else ""
        return f"the file system{where} is full"
    reason = (exc.strerror or "").strip().rstrip(".").lower()
    if not reason:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        reason = (lines[0] if lines else "an error of the system").rstrip(".")
    name = exc.filename if isinstance(exc.filename, str | Path) else None
    return f"{name}: {reason}" if name and str(name) not in reason else reason


@contextlib.contextmanager
def _write_errors(path: Path) -> Iterator[None]:
    """Turn an OSError of writing ``path`` (a full disk, a lost permission) into one sentence
    (WriteFailure)."""
    try:
        yield
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise WriteFailure(f"writing {path} failed: the file system of {path.parent} is full; "
                               "free some space and run the command again") from None
        reason = (exc.strerror or "").strip().rstrip(".").lower() or os_error_reason(exc)
        raise WriteFailure(f"writing {path} failed: {reason}") from None


@contextlib.contextmanager
def staging_folder(path: Path) -> Iterator[Path]:
    """A temporary folder beside ``path`` (named like its temporaries, so that a killed
    writer's folder is cleaned like them), removed with what is left in it afterwards: where a
    writer makes several files (a raster and its side files) before they are placed."""
    with _write_errors(path):
        folder = Path(tempfile.mkdtemp(prefix=_prefix(path), suffix=f".part{path.suffix}.d",
                                       dir=path.parent or Path(".")))
    try:
        with _write_errors(path):
            yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def place(staged: Path, final: Path) -> None:
    """Move a finished side file (``.hdr``, ``.prj``, ``.aux.xml``) onto ``final``, recorded
    among the files this process wrote (exclusively where it is new: see
    :meth:`OutputPlan.put_in_place`)."""
    with _write_errors(final):
        active_plan().put_in_place(staged, final)


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success put it in place as ``path``.

    On any exception the temporary file is removed and ``path`` is left untouched, so no
    half-written output ever appears under the final name. An existing ``path`` that this
    job's plan neither cleared nor wrote is never replaced (InputError); a new one is created
    exclusively (RunFailure when another process wrote it meanwhile). An OSError of the write
    (a full disk) is a WriteFailure.
    """
    with _write_errors(path):
        fd, tmp_name = tempfile.mkstemp(
            prefix=_prefix(path), suffix=f".part{path.suffix}", dir=path.parent or Path(".")
        )
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        with _write_errors(path):
            yield tmp
            plan = active_plan()
            if path.exists() and not plan.may_replace(path):
                raise InputError(f"output {path} already exists; pass --overwrite to replace it.")
            os.chmod(tmp, 0o666 & ~_umask())
            plan.put_in_place(tmp, path)
    finally:
        for leftover in (tmp, Path(f"{tmp}.aux.xml")):
            with contextlib.suppress(FileNotFoundError):
                leftover.unlink()


def _prefix(path: Path) -> str:
    """The start of the name of a temporary of ``path``: ``.STEM.PID.TOKEN`` (this process, the
    active plan's token), before the random characters."""
    return f".{path.stem}.{os.getpid()}.{active_plan().token}"


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
