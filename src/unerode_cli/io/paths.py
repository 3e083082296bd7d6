"""Output-path rules (refuse clobbering, never write over an input, write atomically) and
content digests of files.

Every file is written through :func:`atomic_path`: a temporary file beside the output, named
``.STEM.PID.XXXX.partSUFFIX``, renamed onto the output when complete. The process keeps two
lists: the outputs that :func:`check_output` cleared (before any work) and the files it has
written so far (:func:`written_files`). At write time an existing file that is in neither is
never replaced, whatever the caller asked, so a file that escaped the checks is refused rather
than clobbered. Temporaries left by a killed process (whose PID is gone) are removed by the
next :func:`check_output` of the same output.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from unerode_cli.errors import InputError

_CLEARED: set[Path] = set()
_WRITTEN: list[Path] = []


def check_output(path: Path, overwrite: bool, inputs: tuple[Path, ...] = ()) -> None:
    """Refuse an output that exists (without ``overwrite``), is an input, is a folder or has no
    folder; once cleared, the output may be written (and replaced) by this process. Stale
    temporaries of earlier, killed writers of this output are removed."""
    for src in inputs:
        if path.exists() and src.exists() and path.resolve() == src.resolve():
            raise InputError(f"output {path} is also an input; inputs are never overwritten.")
    if path.is_dir():
        raise InputError(f"output {path} is a folder, not a file name.")
    if path.exists() and not overwrite:
        raise InputError(f"output {path} already exists; pass --overwrite to replace it.")
    if not path.parent.exists():
        raise InputError(f"the folder of output {path} does not exist.")
    _CLEARED.add(path.resolve())
    remove_stale_temporaries(path)


def written_files() -> list[Path]:
    """The files this process has written under their final names, in order."""
    return list(_WRITTEN)


def discard_written() -> list[Path]:
    """Delete every file this process has written (a run that failed keeps nothing); returns
    the deleted paths."""
    removed = []
    for path in _WRITTEN:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
            removed.append(path)
    _WRITTEN.clear()
    return removed


def forget_writes() -> None:
    """Start a new command: no output cleared, nothing written yet."""
    _CLEARED.clear()
    _WRITTEN.clear()
    _STALE.clear()


def remove_stale_temporaries(path: Path) -> list[Path]:
    """Delete the temporaries of ``path`` (files, and staging folders of GDAL side files) left
    by writers that no longer run; returns what was deleted. The folder is listed once per
    process, so clearing many outputs in one folder stays cheap."""
    removed = []
    for candidate in _stale_temporaries(path.parent).pop((path.stem, path.suffix), []):
        _delete(candidate)
        removed.append(candidate)
    return removed


def remove_own_temporaries() -> list[Path]:
    """Delete the temporaries this process left beside its outputs (an interrupt may land
    between a temporary's creation and its clean-up); returns what was deleted."""
    folders = {path.parent for path in _CLEARED} | {path.parent for path in _WRITTEN}
    removed = []
    for folder in folders:
        for candidate in folder.iterdir() if folder.is_dir() else ():
            match = _TEMPORARY.match(candidate.name)
            if match and int(match["pid"]) == os.getpid():
                _delete(candidate)
                removed.append(candidate)
    return removed


def _delete(temporary: Path) -> None:
    """Remove a temporary file or staging folder (gone already is fine)."""
    if temporary.is_dir():
        shutil.rmtree(temporary, ignore_errors=True)
    else:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()


_TEMPORARY = re.compile(r"^\.(?P<stem>.+)\.(?P<pid>\d+)\.[^.]+\.part(?P<suffix>\.[^.]*)?(?:\.d)?$")
_STALE: dict[Path, dict[tuple[str, str], list[Path]]] = {}


def _stale_temporaries(folder: Path) -> dict[tuple[str, str], list[Path]]:
    """(stem, suffix) of an output → temporaries of it in ``folder`` whose writer is gone."""
    key = folder.resolve() if folder.is_dir() else folder
    if key not in _STALE:
        found: dict[tuple[str, str], list[Path]] = {}
        for candidate in folder.iterdir() if folder.is_dir() else ():
            match = _TEMPORARY.match(candidate.name)
            if match and not _running(int(match["pid"])):
                found.setdefault((match["stem"], match["suffix"] or ""), []).append(candidate)
        _STALE[key] = found
    return _STALE[key]


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
    _WRITTEN.append(final)


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it onto ``path``.

    On any exception the temporary file is removed and ``path`` is left untouched, so no
    half-written output ever appears under the final name. An existing ``path`` that this
    process neither cleared with :func:`check_output` nor wrote is never replaced.
    """
    fd, tmp_name = tempfile.mkstemp(
        prefix=f".{path.stem}.{os.getpid()}.", suffix=f".part{path.suffix}", dir=path.parent or Path(".")
    )
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        if path.exists() and path.resolve() not in _CLEARED | {p.resolve() for p in _WRITTEN}:
            raise InputError(f"output {path} already exists; pass --overwrite to replace it.")
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
        _WRITTEN.append(path)
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
