"""Bad inputs and hostile cases of every subcommand (issue 45), and the runner that checks them.

Each :class:`Case` is a command line run in a fresh folder that its ``setup`` fills (copies of
``sample_dems/``, small rasters, tables, specs), with what the issue demands of it: the exit
code (2: bad input refused before any computation; 1: a run that could not finish; 130: an
interrupt), optionally a phrase the message must contain. :func:`run_case` runs one and checks

* (a) the exit code;
* (b) stderr is one sentence (one line ending with a full stop, a final line break allowed), with
  no traceback and no Python class name (``ValueError``, ``RuntimeWarning``, ``CPLE_...``);
  a command that succeeds may print several lines, but no class name either;
* (c) every file of the folder from before the run is byte-identical afterwards (SHA-256), except
  the leftovers a case says the run must remove (``vanish``), which must be gone;
* (d) no new file or folder besides the ones the case allows (``may_create``, globs relative to
  the folder; none for a refused or failed run, hidden temporaries ``.*.part*`` included).

The expected values are what the issue asks for, not what the code does today. Cases run in
process (typer's ``CliRunner`` in the case folder, fast) or each in its own interpreter
(``python -m unerode_cli``); an interrupt case always runs in its own interpreter, which gets a
real SIGINT once the run has written what ``Interrupt.when`` names. A case may not run past its
``timeout`` (a soft limit in process: checked between Python statements) nor allocate more than
:data:`MEMORY_GUARD` bytes beyond what the process had (``RLIMIT_AS``), so that a command that
accepts an absurd size fails here instead of exhausting the machine.

This module imports ``unerode_cli`` only when a case runs, from ``sys.path`` (``PYTHONPATH``
first), so that ``PYTHONPATH=OTHER/src`` probes another copy of the code.
"""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "sample_dems"

#: The issue's classes of defects (and the ordinary bad inputs), as the tables name them.
C0 = "0 ordinary bad input"
C1 = "1 input overwritten / outputs clash"
C2 = "2 refused late (output folder, long names)"
C3 = "3 absurd sizes and step counts"
C4 = "4 exception text"
C5 = "5 non-finite geometry"
C6 = "6 clean-up and kept-file lists"
C7 = "7 misleading messages"
C8 = "8 specs outside their folder"
CLASSES = (C0, C1, C2, C3, C4, C5, C6, C7, C8)

#: Bytes of address space a case may take beyond what the process had before it.
MEMORY_GUARD = 8 * 2**30
#: Python class names and tracebacks, never part of a message.
CLASS_NAME = re.compile(r"Traceback|\b[A-Z][A-Za-z0-9]*(?:Error|Exception|Warning|Interrupt)\b|\bCPLE_\w+")
#: Seconds a case with an absurd size or step count may run (it should be refused at once).
ABSURD = 15.0
#: A file of a dead writer's temporaries (PID 99999999 exceeds any pid_max).
DEAD_PID = 99999999


class Skip(Exception):
    """A case that cannot be set up on this machine (the reason is the message)."""


class CaseTimeout(BaseException):
    """Raised in the main thread when an in-process case runs past its timeout."""


Cleanup = Callable[[], None]
Setup = Callable[[Path], "Cleanup | None"]


@dataclass(frozen=True)
class Interrupt:
    """Send SIGINT once ``count`` versions of the files matching ``when`` (a glob relative to
    the case folder) have been seen, or after ``after`` seconds when nothing matches."""

    when: str
    count: int = 1
    after: float = 60.0


@dataclass(frozen=True)
class Case:
    """One command line and what the issue demands of it (see the module docstring)."""

    name: str
    cls: str
    argv: tuple[str, ...]
    setup: tuple[Setup, ...] = ()
    exits: tuple[int, ...] = (2,)
    phrase: str = ""
    absent: tuple[str, ...] = ()
    may_create: tuple[str, ...] = ()
    vanish: tuple[str, ...] = ()
    once: tuple[str, ...] = ()
    interrupt: Interrupt | None = None
    timeout: float = 60.0

    @property
    def subcommand(self) -> str:
        return self.argv[0]


@dataclass
class Outcome:
    """What one case did: exit code, stderr, the failed checks (empty: passed), wall time (s)."""

    case: Case
    exit_code: int | None = None
    stderr: str = ""
    failures: list[str] = field(default_factory=list)
    seconds: float = 0.0
    skipped: str = ""

    @property
    def passed(self) -> bool:
        return not self.failures and not self.skipped


# ---------------------------------------------------------------------------------------------
# Setup steps: each makes files in the case folder and may return a clean-up.

def _ramp(rows: int, cols: int) -> np.ndarray:
    """A surface tilted towards the south edge with small bumps (m)."""
    r, c = np.indices((rows, cols))
    return 100.0 + 3.0 * (rows - 1 - r) + 2.0 * np.sin(c * 0.9) * np.cos(r * 0.7)


def dem(name: str, rows: int = 24, cols: int = 24, *, crs: str | None = "EPSG:32632",
        dx: float = 30.0, origin: tuple[float, float] = (500000.0, 5000000.0),
        values: str | float = "ramp", nodata: float | None = None, dtype: str = "float32",
        bands: int = 1, driver: str = "GTiff") -> Setup:
    """A small raster: ``values`` is ``ramp``, ``steep`` (a ramp 20 times as steep: slopes up to
    about 65°), ``nan`` (every cell NaN), ``spike`` (one cell at
    1e300 m, float64), ``extreme`` (cells of ±1e308 m, float64) or a constant."""

    def make(folder: Path) -> None:
        import rasterio
        from affine import Affine

        if values in ("ramp", "steep"):
            z = _ramp(rows, cols) * (20.0 if values == "steep" else 1.0)
        elif values == "nan":
            z = np.full((rows, cols), np.nan)
        elif values == "spike":
            z = _ramp(rows, cols)
            z[rows // 2, cols // 2] = 1e300
        elif values == "extreme":
            z = np.zeros((rows, cols))
            z[::2, ::2], z[1::2, 1::2] = 1e308, -1e308
        else:
            z = np.full((rows, cols), float(values))
        transform = Affine(dx, 0.0, origin[0], 0.0, -dx, origin[1])
        profile = {"driver": driver, "height": rows, "width": cols, "count": bands,
                   "dtype": dtype, "transform": transform, "nodata": nodata}
        if crs is not None:
            profile["crs"] = crs
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        with rasterio.open(folder / name, "w", **profile) as dst:
            for band in range(1, bands + 1):
                dst.write(z.astype(dtype), band)

    return make


def sample(name: str, to: str | None = None) -> Setup:
    """A copy of ``sample_dems/NAME`` (named ``to``)."""

    def make(folder: Path) -> None:
        source = SAMPLES / name
        if not source.exists():
            raise Skip(f"{source} is missing")
        target = folder / (to or name)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source, target)

    return make


def text(name: str, content: str) -> Setup:
    """A text file (its folders made)."""

    def make(folder: Path) -> None:
        target = folder / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(content)

    return make


def mkdir(name: str) -> Setup:
    def make(folder: Path) -> None:
        (folder / name).mkdir(parents=True, exist_ok=True)

    return make


def symlink(name: str, target: str) -> Setup:
    """``name`` → ``target`` (relative to the link's folder)."""

    def make(folder: Path) -> None:
        (folder / name).symlink_to(target)

    return make


def hardlink(name: str, target: str) -> Setup:
    def make(folder: Path) -> None:
        os.link(folder / target, folder / name)

    return make


def readonly(name: str) -> Setup:
    """A folder that cannot be written: mode 0555, and immutable (``chattr +i``) for root,
    whom modes do not stop; skipped where neither works."""

    def make(folder: Path) -> Cleanup:
        path = folder / name
        path.mkdir(parents=True, exist_ok=True)
        path.chmod(0o555)
        immutable = False
        if os.access(path, os.W_OK) and shutil.which("chattr"):
            immutable = subprocess.run(["chattr", "+i", str(path)], capture_output=True).returncode == 0

        def undo() -> None:
            if immutable:
                subprocess.run(["chattr", "-i", str(path)], capture_output=True)
            path.chmod(0o755)

        if os.access(path, os.W_OK):
            undo()
            raise Skip("no read-only folder can be made here (root, and chattr +i refused)")
        return undo

    return make


def huge_tif(name: str, size: int = 200_000) -> Setup:
    """A GeoTIFF declaring ``size``² float32 cells with no block written (sparse: a few MB)."""

    def make(folder: Path) -> None:
        import rasterio
        from affine import Affine

        profile = {"driver": "GTiff", "height": size, "width": size, "count": 1, "dtype": "float32",
                   "crs": "EPSG:32632", "transform": Affine(30.0, 0, 500000.0, 0, -30.0, 5000000.0),
                   "tiled": True, "blockxsize": 512, "blockysize": 512, "sparse_ok": True,
                   "compress": "deflate", "bigtiff": "yes", "nodata": -9999.0}
        with rasterio.open(folder / name, "w", **profile):
            pass

    return make


def png(name: str) -> Setup:
    """A plain 16 × 16 PNG picture (no georeferencing)."""

    def make(folder: Path) -> None:
        import warnings

        import rasterio

        with warnings.catch_warnings():  # rasterio warns of the missing georeferencing, by design
            warnings.simplefilter("ignore")
            with rasterio.open(folder / name, "w", driver="PNG", height=16, width=16, count=1,
                               dtype="uint8") as dst:
                dst.write(np.arange(256, dtype=np.uint8).reshape(16, 16), 1)

    return make


def exr_header(name: str, **attributes: str) -> Setup:
    """``sample_dems/fractal_30m.exr`` with its ``unerode.*`` header attributes replaced."""

    def make(folder: Path) -> None:
        import OpenEXR

        source = SAMPLES / "fractal_30m.exr"
        if not source.exists():
            raise Skip(f"{source} is missing")
        with OpenEXR.File(str(source), separate_channels=True) as exr:
            header = dict(exr.header())
            pixels = {key: channel.pixels.copy() for key, channel in exr.channels().items()}
        for key in [k for k in header if k not in ("compression", "type") and not k.startswith("unerode.")]:
            del header[key]
        header.update({f"unerode.{key}": value for key, value in attributes.items()})
        OpenEXR.File(header, pixels).write(str(folder / name))

    return make


def stale(output: str) -> Setup:
    """Leftovers of a killed writer of ``output``: a GDAL side file of its temporary and a
    staging folder (PID :data:`DEAD_PID`, which runs nowhere)."""

    def make(folder: Path) -> None:
        stem, suffix = Path(output).stem, Path(output).suffix
        parent = (folder / output).parent
        (parent / f".{stem}.{DEAD_PID}.k3j2.part{suffix}.aux.xml").write_text("<PAMDataset/>\n")
        staging = parent / f".{stem}.{DEAD_PID}.q7w1.part{suffix}.d"
        staging.mkdir()
        (staging / f"{stem}{suffix}").write_bytes(b"half-written")

    return make


def stale_names(output: str) -> tuple[str, ...]:
    stem, suffix = Path(output).stem, Path(output).suffix
    parent = str(Path(output).parent)
    prefix = "" if parent == "." else parent + "/"
    return (f"{prefix}.{stem}.{DEAD_PID}.k3j2.part{suffix}.aux.xml",
            f"{prefix}.{stem}.{DEAD_PID}.q7w1.part{suffix}.d")


def long_name(length: int = 250, suffix: str = ".tif") -> str:
    """A file name of ``length`` characters: valid alone, too long once a hidden temporary's
    ``.NAME.PID.XXXX.part`` decoration is added (names are at most 255 bytes)."""
    return "n" * (length - len(suffix)) + suffix


# ---------------------------------------------------------------------------------------------
# Running a case and checking it.

def snapshot(folder: Path) -> dict[str, str]:
    """Relative path → SHA-256 of every file under ``folder`` ('dir' for folders, 'link:TARGET'
    for symbolic links, which are not followed)."""
    found: dict[str, str] = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = Path(root) / name
            rel = str(path.relative_to(folder))
            if path.is_symlink():
                found[rel] = f"link:{os.readlink(path)}"
            elif path.is_dir():
                found[rel] = "dir"
            else:
                digest = hashlib.sha256()
                with contextlib.suppress(OSError), open(path, "rb") as handle:
                    for block in iter(lambda h=handle: h.read(1 << 20), b""):
                        digest.update(block)
                found[rel] = digest.hexdigest()
    return found


def check_message(stderr: str, exit_code: int) -> list[str]:
    """(b): one sentence (failed or refused runs), no class name or traceback (any run)."""
    failures = []
    match = CLASS_NAME.search(stderr)
    if match:
        failures.append(f"stderr names {match.group(0)!r}")
    if exit_code != 0:
        body = stderr[:-1] if stderr.endswith("\n") else stderr
        if not body.strip():
            failures.append("stderr is empty")
        elif "\n" in body:
            failures.append(f"stderr has {body.count(chr(10)) + 1} lines, not one sentence")
        elif not body.rstrip().endswith("."):
            failures.append("stderr does not end a sentence ('.')")
    return failures


def check_files(case: Case, before: dict[str, str], after: dict[str, str]) -> list[str]:
    """(c) inputs byte-identical, (d) nothing new but what the case allows, leftovers gone."""
    failures = []
    changed = [p for p, digest in before.items()
               if p not in case.vanish and not p.startswith(tuple(v + "/" for v in case.vanish))
               and after.get(p) != digest]
    if changed:
        failures.append(f"input changed or removed: {', '.join(sorted(changed)[:4])}")
    new = [p for p in after if p not in before]
    unexpected = [p for p in new if not any(fnmatch.fnmatch(p, g) for g in case.may_create)
                  and not any(p.startswith(q + "/") for q in new if q != p and after[q] == "dir"
                              and any(fnmatch.fnmatch(q, g) for g in case.may_create))]
    if unexpected:
        failures.append(f"new file(s): {', '.join(sorted(unexpected)[:4])}"
                        + (f" and {len(unexpected) - 4} more" if len(unexpected) > 4 else ""))
    kept = [v for v in case.vanish if v in after]
    if kept:
        failures.append(f"leftover(s) not removed: {', '.join(kept)}")
    return failures


def check_outcome(case: Case, code: int | None, stderr: str) -> list[str]:
    """(a) the exit code, (b) the message, and the case's phrases."""
    failures = []
    if code is None:
        return failures
    if code not in case.exits:
        want = " or ".join(map(str, case.exits))
        failures.append(f"exit {code}, expected {want}")
    failures += check_message(stderr, code)
    low = stderr.lower()
    if case.phrase and case.phrase.lower() not in low:
        failures.append(f"message lacks {case.phrase!r}")
    failures += [f"message says {bad!r}" for bad in case.absent if bad.lower() in low]
    failures += [f"message names {item!r} {low.count(item.lower())} times" for item in case.once
                 if low.count(item.lower()) > 1]
    return failures


def run_case(case: Case, folder: Path, isolated: bool = False) -> Outcome:
    """Set ``case`` up in the new folder ``folder``, run it (in this process unless
    ``isolated`` or an interrupt case) and check it; the folder is left for inspection."""
    outcome = Outcome(case)
    folder.mkdir(parents=True, exist_ok=False)
    cleanups: list[Cleanup] = []
    try:
        for step in case.setup:
            undo = step(folder)
            if undo is not None:
                cleanups.append(undo)
        before = snapshot(folder)
        start = time.perf_counter()
        if isolated or case.interrupt is not None:
            code, stderr, note = _run_subprocess(case, folder)
        else:
            code, stderr, note = _run_in_process(case, folder)
        outcome.seconds = time.perf_counter() - start
        outcome.exit_code, outcome.stderr = code, stderr
        if note:
            outcome.failures.append(note)
        outcome.failures += check_outcome(case, code, stderr)
        outcome.failures += check_files(case, before, snapshot(folder))
    except Skip as exc:
        outcome.skipped = str(exc)
    finally:
        for undo in reversed(cleanups):
            undo()
    return outcome


def _child_environment() -> dict[str, str]:
    """The environment of a case's own interpreter: the same ``unerode_cli`` as this process."""
    import unerode_cli

    source = str(Path(unerode_cli.__file__).resolve().parents[1])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([source, *filter(None, [env.get("PYTHONPATH")])])
    env.setdefault("COLUMNS", "100")
    return env


def _address_space() -> int:
    """Bytes of address space this process maps now."""
    with open("/proc/self/status") as handle:
        for line in handle:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


@contextlib.contextmanager
def _memory_guard(extra: int) -> Iterator[None]:
    """Limit the address space to its size now + ``extra`` bytes, restored afterwards."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = _address_space() + extra
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


@contextlib.contextmanager
def _alarm(seconds: float) -> Iterator[list[bool]]:
    """Raise :class:`CaseTimeout` in the main thread after ``seconds``; the yielded list holds
    True once it fired (a command may turn the exception into another, e.g. numba's
    SystemError, so the flag, not the exception, tells a timeout)."""
    fired: list[bool] = []

    def fire(signum, frame):  # noqa: ARG001 - signal handler signature
        fired.append(True)
        raise CaseTimeout

    previous = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield fired
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@contextlib.contextmanager
def _warnings_to_stderr() -> Iterator[None]:
    """Warnings printed on (the current) stderr, filtered as in a plain interpreter, as a command
    run from a shell prints them (pytest would record them and show deprecations)."""
    import warnings

    def show(message, category, filename, lineno, file=None, line=None):  # noqa: ARG001
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))

    with warnings.catch_warnings():
        warnings.resetwarnings()  # the filters of a plain interpreter, not pytest's
        for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
            warnings.filterwarnings("ignore", category=category)
        warnings.showwarning = show
        yield


def _run_in_process(case: Case, folder: Path) -> tuple[int | None, str, str]:
    """Run the case with typer's CliRunner in ``folder``: (exit code, stderr, failure note)."""
    from typer.testing import CliRunner

    from unerode_cli.cli.app import app

    try:
        runner = CliRunner(mix_stderr=False)  # click < 8.2
    except TypeError:
        runner = CliRunner()
    cwd = os.getcwd()
    os.chdir(folder)
    timeout = f"still running after {case.timeout:g} s (stopped by the probe)"
    try:
        with _memory_guard(MEMORY_GUARD), _alarm(case.timeout) as fired, _warnings_to_stderr():
            result = runner.invoke(app, list(case.argv), catch_exceptions=True,
                                   env={"COLUMNS": "100"})
    except CaseTimeout:
        return None, "", timeout
    finally:
        os.chdir(cwd)
    if fired:
        return None, result.stderr, timeout
    note = ""
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        note = f"an exception escaped the command: {type(result.exception).__name__}"
    return result.exit_code, result.stderr, note


def _watch(case: Case, folder: Path, fire: Callable[[], None], done: threading.Event) -> None:
    """Call ``fire`` once ``case.interrupt.when`` has been seen ``count`` times (or after
    ``after`` seconds); stop when ``done`` is set."""
    interrupt = case.interrupt
    assert interrupt is not None
    seen: set[tuple[str, int]] = set()
    start = time.monotonic()
    while not done.wait(0.02):
        for path in folder.glob(interrupt.when):
            with contextlib.suppress(OSError):
                seen.add((path.name, path.stat().st_mtime_ns))
        if len(seen) >= interrupt.count or time.monotonic() - start > interrupt.after:
            fire()
            return


def _run_subprocess(case: Case, folder: Path) -> tuple[int | None, str, str]:
    """Run the case as ``python -m unerode_cli`` in ``folder``: (exit code, stderr, note)."""
    limit = _address_space() + MEMORY_GUARD

    def limited() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (max(limit, 12 * 2**30), resource.RLIM_INFINITY))

    proc = subprocess.Popen([sys.executable, "-m", "unerode_cli", *case.argv], cwd=folder,
                            env=_child_environment(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=limited, start_new_session=True)
    done = threading.Event()
    watcher = None
    if case.interrupt is not None:
        watcher = threading.Thread(target=_watch, args=(case, folder, lambda: proc.send_signal(signal.SIGINT),
                                                        done), daemon=True)
        watcher.start()
    try:
        _, stderr = proc.communicate(timeout=case.timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        _, stderr = proc.communicate()
        return None, stderr, f"still running after {case.timeout:g} s (killed by the probe)"
    finally:
        done.set()
        if watcher is not None:
            watcher.join()
    return proc.returncode, stderr, ""


def spec_yaml(spec: dict) -> str:
    """A spec as YAML text (JSON is YAML)."""
    return json.dumps(spec, indent=1) + "\n"


def spec(name: str, build: dict | Callable[[Path], dict]) -> Setup:
    """A pipeline or ensemble spec written as YAML (``build``: the spec, or a function of the
    case folder that returns it, for specs naming absolute paths)."""

    def make(folder: Path) -> None:
        content = build(folder) if callable(build) else build
        target = folder / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(spec_yaml(content))

    return make


# ---------------------------------------------------------------------------------------------
# The table. Names: SUBCOMMAND-what; in.tif is a 24 × 24 ramp (UTM 32N, 30 m) unless said.

IN = dem("in.tif")
#: A δ18O chronology (age ka, ‰) covering 0-30 ka.
CHRONOLOGY = text("c.csv", "age_ka,d18o\n0,3.2\n5,3.5\n10,4.0\n15,4.6\n20,4.9\n25,4.7\n30,4.4\n")
RAIN = ("--iterations", "1", "--particles", "5")
CLIMATE = ("--chronology", "c.csv", "--to", "2", "--dt", "1000")
OUTS = ("out.tif", "out.tif.json", "out.tif.aux.xml")
POLAR = dem("polar.tif", crs="EPSG:4326", dx=0.5, origin=(8.0, 93.0))
LINE = '{"type": "LineString", "coordinates": [[500100, 4999600], [500500, 4999400]]}\n'
OBSERVATIONS = "age_ka,height_above_river_m\n1,5\n"
SCENE = "shape:\n  box: {min: [0, 0, 0], max: [8, 8, 6]}\nlayers:\n  - {k_w: 1e-4}\n"


def info_cases() -> list[Case]:
    return [
        Case("info-missing-file", C0, ("info", "nope.tif"), phrase="does not exist"),
        Case("info-text-file", C0, ("info", "notes.tif"), (text("notes.tif", "hello\n"),),
             phrase="not a raster"),
        Case("info-band-out-of-range", C0, ("info", "in.tif", "--band", "3"), (IN,), phrase="band 3"),
        Case("info-folder-as-dem", C0, ("info", "adir"), (mkdir("adir"),), phrase="folder"),
        Case("info-exr-malformed-transform", C4, ("info", "bad.exr"),
             (exr_header("bad.exr", transform="[30, 0, 0,", cellSize="30 30"),)),
        Case("info-exr-malformed-cellsize", C4, ("info", "bad.exr"),
             (exr_header("bad.exr", transform="[30, 0, 0, 0, -30, 0]", cellSize="thirty"),)),
        Case("info-exr-malformed-nodata", C4, ("info", "bad.exr"),
             (exr_header("bad.exr", transform="[30, 0, 0, 0, -30, 0]", cellSize="30 30", nodata="{"),)),
        Case("info-huge-declared-raster", C3, ("info", "huge.tif"), (huge_tif("huge.tif"),), phrase="memory"),
        Case("info-rows-past-the-pole", C5, ("info", "polar.tif"), (POLAR,)),
        Case("info-nan-cell-size", C5, ("info", "nancell.tif"), (dem("nancell.tif", dx=float("nan")),)),
    ]


def convert_cases() -> list[Case]:
    return [
        Case("convert-output-is-input", C0, ("convert", "in.tif", "in.tif", "--overwrite"), (IN,),
             phrase="input"),
        Case("convert-output-symlink-to-input", C1, ("convert", "in.tif", "link.tif", "--overwrite"),
             (IN, symlink("link.tif", "in.tif"))),
        Case("convert-output-hardlink-to-input", C1, ("convert", "in.tif", "twin.tif", "--overwrite"),
             (IN, hardlink("twin.tif", "in.tif"))),
        Case("convert-preview-is-output", C1, ("convert", "in.tif", "out.tif", "--preview", "out.tif"),
             (IN,)),
        Case("convert-preview-is-input", C1,
             ("convert", "in.tif", "out.tif", "--preview", "in.tif", "--overwrite"),
             (IN,)),
        Case("convert-existing-output", C0, ("convert", "in.tif", "out.tif"),
             (IN, text("out.tif", "precious")),
             phrase="--overwrite"),
        Case("convert-missing-folder", C2, ("convert", "in.tif", "nowhere/out.tif"), (IN,)),
        Case("convert-readonly-folder", C2, ("convert", "in.tif", "ro/out.tif"), (IN, readonly("ro"))),
        Case("convert-folder-is-a-file", C2, ("convert", "in.tif", "afile/out.tif"),
             (IN, text("afile", "x"))),
        Case("convert-name-too-long", C2, ("convert", "in.tif", long_name()), (IN,)),
        Case("convert-cell-size-tiny", C3, ("convert", "in.tif", "out.tif", "--cell-size", "0.001"), (IN,),
             phrase="memory"),
        Case("convert-crop-of-huge-raster", C3,
             ("convert", "huge.tif", "out.tif", "--crop", "500000,4999000,501000,5000000"),
             (huge_tif("huge.tif"),), exits=(0,), may_create=OUTS),
        Case("convert-z-scale-1e308", C5, ("convert", "in.tif", "out.tif", "--z-scale", "1e308"), (IN,)),
        Case("convert-rows-past-the-pole", C5, ("convert", "polar.tif", "out.tif"), (POLAR,)),
        Case("convert-z-scale-inf", C5, ("convert", "in.tif", "out.tif", "--z-scale", "inf"), (IN,)),
        Case("convert-cell-size-nan", C5, ("convert", "in.tif", "out.tif", "--cell-size", "nan"), (IN,)),
        Case("convert-output-is-a-folder", C7, ("convert", "in.tif", "out.tif"), (IN, mkdir("out.tif")),
             phrase="folder", absent=("extension",)),
        Case("convert-output-folder-without-suffix", C7, ("convert", "in.tif", "outdir"),
             (IN, mkdir("outdir")),
             phrase="folder", absent=("extension",)),
        Case("convert-png-as-dem", C7, ("convert", "pic.png", "out.tif"), (png("pic.png"),),
             phrase="not georeferenced"),
        Case("convert-bad-creation-option", C0, ("convert", "in.tif", "out.tif", "--co", "NOEQUALS"), (IN,)),
        Case("convert-negative-z-scale", C0, ("convert", "in.tif", "out.tif", "--z-scale", "-1"), (IN,)),
        Case("convert-crop-outside-the-dem", C0, ("convert", "in.tif", "out.tif", "--crop", "0,0,10,10"),
             (IN,)),
        Case("convert-removes-stale-leftovers", C6, ("convert", "in.tif", "out.tif"), (IN, stale("out.tif")),
             exits=(0,), may_create=OUTS, vanish=stale_names("out.tif")),
    ]


def preview_cases() -> list[Case]:
    return [
        Case("preview-png-is-the-dem", C1, ("preview", "in.tif", "in.tif", "--overwrite"), (IN,)),
        Case("preview-missing-folder", C2, ("preview", "in.tif", "nowhere/p.png"), (IN,)),
        Case("preview-readonly-folder", C2, ("preview", "in.tif", "ro/p.png"), (IN, readonly("ro"))),
        Case("preview-name-too-long", C2, ("preview", "in.tif", long_name(suffix=".png")), (IN,)),
        Case("preview-output-is-a-folder", C7, ("preview", "in.tif", "p.png"), (IN, mkdir("p.png")),
             phrase="folder"),
        Case("preview-exaggeration-zero", C0, ("preview", "in.tif", "p.png", "--exaggeration", "0"), (IN,)),
        Case("preview-unknown-colour-map", C0, ("preview", "in.tif", "p.png", "--cmap", "no-such-map"),
             (IN,)),
        Case("preview-nan-only-dem", C0, ("preview", "nan.tif", "p.png"), (dem("nan.tif", values="nan"),)),
        Case("preview-huge-declared-raster", C3, ("preview", "huge.tif", "p.png"), (huge_tif("huge.tif"),),
             phrase="memory"),
    ]


def synth_cases() -> list[Case]:
    small = ("--size", "16")
    return [
        Case("synth-dx-1e308", C5, ("synth", "out.tif", *small, "--dx", "1e308")),
        Case("synth-centre-at-the-pole", C5,
             ("synth", "out.tif", *small, "--crs", "EPSG:4326", "--centre", "0,89.99")),
        Case("synth-centre-beyond-the-pole", C5,
             ("synth", "out.tif", *small, "--crs", "EPSG:4326", "--centre", "0,95")),
        Case("synth-dx-zero", C0, ("synth", "out.tif", *small, "--dx", "0")),
        Case("synth-readonly-folder", C2, ("synth", "ro/out.tif", *small), (readonly("ro"),)),
        Case("synth-missing-folder", C2, ("synth", "nowhere/out.tif", *small)),
        Case("synth-folder-is-a-file", C2, ("synth", "afile/out.tif", *small), (text("afile", "x"),)),
        Case("synth-name-too-long", C2, ("synth", long_name(), *small)),
        Case("synth-output-is-a-folder", C7, ("synth", "out.tif", *small), (mkdir("out.tif"),),
             phrase="folder",
             absent=("extension",)),
        Case("synth-preview-is-output", C1, ("synth", "out.tif", *small, "--preview", "out.tif")),
        Case("synth-unknown-crs", C0, ("synth", "out.tif", *small, "--crs", "EPSG:999999")),
        Case("synth-malformed-centre", C0, ("synth", "out.tif", *small, "--centre", "east,north")),
        Case("synth-existing-output", C0, ("synth", "out.tif", *small), (text("out.tif", "precious"),),
             phrase="--overwrite"),
        Case("synth-removes-stale-leftovers", C6, ("synth", "out.tif", *small), (stale("out.tif"),),
             exits=(0,),
             may_create=OUTS, vanish=stale_names("out.tif")),
    ]


def flow_cases() -> list[Case]:
    grid = dem("p.tif", values=1.0)
    return [
        Case("flow-output-is-precipitation", C1, ("flow", "in.tif", "p.tif", "-p", "p.tif", "--overwrite"),
             (IN, grid)),
        Case("flow-output-is-dirichlet", C1,
             ("flow", "in.tif", "p.tif", "--dirichlet", "p.tif", "--overwrite"),
             (IN, grid)),
        Case("flow-preview-is-output", C1, ("flow", "in.tif", "q.tif", "--preview", "q.tif"), (IN,)),
        Case("flow-nan-only-dem", C0, ("flow", "nan.tif", "q.tif"), (dem("nan.tif", values="nan"),)),
        Case("flow-precipitation-other-grid", C0, ("flow", "in.tif", "q.tif", "-p", "p.tif"),
             (IN, dem("p.tif", rows=10, values=1.0))),
        Case("flow-dirichlet-other-crs", C0, ("flow", "in.tif", "q.tif", "--dirichlet", "d.tif"),
             (IN, dem("d.tif", crs="EPSG:32633", values=0.0))),
        Case("flow-precipitation-typo", C7, ("flow", "in.tif", "q.tif", "-p", "1e-5x"), (IN,),
             phrase="number", absent=("does not exist",)),
        Case("flow-png-as-dem", C7, ("flow", "pic.png", "q.tif"), (png("pic.png"),),
             phrase="not georeferenced"),
        Case("flow-readonly-folder", C2, ("flow", "in.tif", "ro/q.tif"), (IN, readonly("ro"))),
        Case("flow-rows-past-the-pole", C5, ("flow", "polar.tif", "q.tif"), (POLAR,)),
        Case("flow-unknown-outlets", C0, ("flow", "in.tif", "q.tif", "--outlets", "X"), (IN,)),
    ]


def erode_cases() -> list[Case]:
    """erode's outputs that clash with its inputs or each other, then erode_more_cases."""
    k = dem("k.tif", values=1e-5)
    two = ("--steps", "2")
    inflow = text("inflow.csv", "x,y,discharge_m3_per_y,sediment_m3_per_y\n500015,4999295,1e6,0\n")
    return [
        Case("erode-k-raster-is-output", C1,
             ("erode", "in.tif", "k.tif", "--K", "k.tif", *two, "--overwrite"),
             (IN, k)),
        Case("erode-k-raster-symlinked-output", C1,
             ("erode", "in.tif", "out.tif", "--K", "k.tif", *two, "--overwrite"),
             (IN, k, symlink("out.tif", "k.tif"))),
        Case("erode-k-raster-hardlinked-output", C1,
             ("erode", "in.tif", "out.tif", "--K", "k.tif", *two, "--overwrite"),
             (IN, k, hardlink("out.tif", "k.tif"))),
        Case("erode-change-map-is-output", C1,
             ("erode", "in.tif", "out.tif", *two, "--change-map", "out.tif"),
             (IN,)),
        Case("erode-change-map-is-input", C1,
             ("erode", "in.tif", "out.tif", *two, "--change-map", "in.tif", "--overwrite"), (IN,)),
        Case("erode-preview-is-change-map", C1,
             ("erode", "in.tif", "out.tif", *two, "--change-map", "c.tif", "--preview", "c.tif"), (IN,)),
        Case("erode-snapshot-is-k-raster", C1,
             ("erode", "in.tif", "out.tif", "--steps", "4", "--snapshot-every", "1000", "--K", "out_002.tif",
              "--overwrite"), (IN, dem("out_002.tif", values=1e-5))),
        Case("erode-params-raster-is-output", C1,
             ("erode", "in.tif", "k.tif", "--params", "p.yaml", *two, "--overwrite"),
             (IN, k, text("p.yaml", "K: k.tif\n"))),
        Case("erode-inflow-is-change-map", C1,
             ("erode", "in.tif", "out.tif", "--inflow", "inflow.csv", "--change-map", "inflow.csv", *two,
              "--overwrite"), (IN, inflow)),
        Case("erode-dirichlet-is-output", C1,
             ("erode", "in.tif", "d.tif", "--dirichlet", "d.tif", *two, "--overwrite"),
             (IN, dem("d.tif", values=0.0))),
    ] + erode_more_cases()


def erode_more_cases() -> list[Case]:
    two = ("--steps", "2")
    return [
        Case("erode-readonly-folder", C2, ("erode", "in.tif", "ro/out.tif", *two), (IN, readonly("ro"))),
        Case("erode-missing-folder", C2, ("erode", "in.tif", "nowhere/out.tif", *two), (IN,)),
        Case("erode-folder-is-a-file", C2, ("erode", "in.tif", "afile/out.tif", *two),
             (IN, text("afile", "x"))),
        Case("erode-name-too-long", C2, ("erode", "in.tif", long_name(), *two), (IN,)),
        Case("erode-change-map-name-too-long", C2,
             ("erode", "in.tif", "out.tif", *two, "--change-map", long_name()),
             (IN,)),
        Case("erode-change-map-readonly-folder", C2,
             ("erode", "in.tif", "out.tif", *two, "--change-map", "ro/c.tif"), (IN, readonly("ro"))),
        Case("erode-duration-1e308", C3, ("erode", "in.tif", "out.tif", "--duration", "1e308"), (IN,),
             timeout=ABSURD),
        Case("erode-steps-absurd", C3, ("erode", "in.tif", "out.tif", "--steps", "1000000000000000"), (IN,),
             timeout=ABSURD),
        Case("erode-dt-tiny", C3, ("erode", "in.tif", "out.tif", "--dt", "1e-300", "--duration", "1000"),
             (IN,),
             timeout=ABSURD),
        Case("erode-k-typo", C7, ("erode", "in.tif", "out.tif", "--K", "1e-5x", *two), (IN,), phrase="number",
             absent=("does not exist",)),
        Case("erode-png-as-dem", C7, ("erode", "pic.png", "out.tif", *two), (png("pic.png"),),
             phrase="not georeferenced"),
        Case("erode-missing-dem", C0, ("erode", "nope.tif", "out.tif", *two), phrase="does not exist"),
        Case("erode-nan-only-dem", C0, ("erode", "nan.tif", "out.tif", *two),
             (dem("nan.tif", values="nan"),)),
        Case("erode-k-raster-other-crs", C0, ("erode", "in.tif", "out.tif", "--K", "k.tif", *two),
             (IN, dem("k.tif", crs="EPSG:32633", values=1e-5))),
        Case("erode-k-raster-other-shape", C0, ("erode", "in.tif", "out.tif", "--K", "k.tif", *two),
             (IN, dem("k.tif", rows=12, values=1e-5))),
        Case("erode-malformed-params", C0, ("erode", "in.tif", "out.tif", "--params", "p.yaml", *two),
             (IN, text("p.yaml", "K: [1, 2\n"))),
        Case("erode-unknown-process", C0, ("erode", "in.tif", "out.tif", "--process", "lava", *two), (IN,)),
        Case("erode-unstable-dt-no-substep", C0,
             ("erode", "steep.tif", "out.tif", "--process", "thermal", "--k-th", "1", "--dt", "1e5",
              "--steps", "1",
              "--no-substep"), (dem("steep.tif", values="steep"),), phrase="unstable"),
        Case("erode-existing-output", C0, ("erode", "in.tif", "out.tif", *two),
             (IN, text("out.tif", "precious")),
             phrase="--overwrite"),
        Case("erode-output-is-input", C0, ("erode", "in.tif", "in.tif", *two, "--overwrite"), (IN,),
             phrase="input"),
        Case("erode-unknown-option", C0, ("erode", "in.tif", "out.tif", "--bogus"), (IN,)),
        Case("erode-thermal-spike-diverges", C4,
             ("erode", "spike.tif", "out.tif", "--process", "thermal", "--force", *two),
             (dem("spike.tif", values="spike", dtype="float64"),), exits=(1,), phrase="diverged"),
        Case("erode-thermal-extreme-elevations", C4,
             ("erode", "x.tif", "out.tif", "--process", "thermal", *two),
             (dem("x.tif", values="extreme", dtype="float64"),), exits=(1, 2)),
        Case("erode-interrupt-lists-checkpoint-once", C6,
             ("erode", "big.tif", "out.tif", "--steps", "1000000", "--dt", "10", "--checkpoint-every", "1"),
             (sample("eroded_utm32n_30m.tif", "big.tif"),), exits=(130,),
             once=(".out.tif.checkpoint.npz",), may_create=(".out.tif.checkpoint.npz",),
             interrupt=Interrupt(".out.tif.checkpoint.npz", count=4), timeout=180),
        Case("erode-removes-stale-leftovers", C6, ("erode", "in.tif", "out.tif", "--steps", "1"),
             (IN, stale("out.tif")), exits=(0,), may_create=OUTS, vanish=stale_names("out.tif")),
    ]


def unerode_cases() -> list[Case]:
    two = ("--steps", "2")
    return [
        Case("unerode-k-1e308", C4, ("unerode", "in.tif", "out.tif", "--K", "1e308", *two), (IN,),
             exits=(1, 2),
             absent=("non-positive stable time step",)),
        Case("unerode-k-raster-is-output", C1,
             ("unerode", "in.tif", "k.tif", "--K", "k.tif", *two, "--overwrite"),
             (IN, dem("k.tif", values=1e-5))),
        Case("unerode-change-map-is-output", C1,
             ("unerode", "in.tif", "out.tif", *two, "--change-map", "out.tif"), (IN,)),
        Case("unerode-forward-only-process", C0,
             ("unerode", "in.tif", "out.tif", "--process", "hillslope", *two),
             (IN,)),
        Case("unerode-readonly-folder", C2, ("unerode", "in.tif", "ro/out.tif", *two), (IN, readonly("ro"))),
        Case("unerode-duration-1e308", C3, ("unerode", "in.tif", "out.tif", "--duration", "1e308"), (IN,),
             timeout=ABSURD),
        Case("unerode-unstable-dt-no-substep", C0,
             ("unerode", "steep.tif", "out.tif", "--process", "thermal", "--k-th", "1", "--dt", "1e5",
              "--steps", "1",
              "--no-substep"), (dem("steep.tif", values="steep"),), phrase="unstable"),
    ]


def diff_cases() -> list[Case]:
    a, b = dem("a.tif"), dem("b.tif", values=120.0)
    return [
        Case("diff-output-is-a", C1, ("diff", "a.tif", "b.tif", "a.tif", "--overwrite"), (a, b)),
        Case("diff-output-symlink-to-b", C1, ("diff", "a.tif", "b.tif", "d.tif", "--overwrite"),
             (a, b, symlink("d.tif", "b.tif"))),
        Case("diff-preview-is-output", C1, ("diff", "a.tif", "b.tif", "d.tif", "--preview", "d.tif"), (a, b)),
        Case("diff-other-grid", C0, ("diff", "a.tif", "c.tif", "d.tif"), (a, dem("c.tif", rows=20))),
        Case("diff-other-crs", C0, ("diff", "a.tif", "c.tif", "d.tif"), (a, dem("c.tif", crs="EPSG:32633"))),
        Case("diff-readonly-folder", C2, ("diff", "a.tif", "b.tif", "ro/d.tif"), (a, b, readonly("ro"))),
        Case("diff-folder-is-a-file", C2, ("diff", "a.tif", "b.tif", "afile/d.tif"),
             (a, b, text("afile", "x"))),
        Case("diff-missing-a", C0, ("diff", "nope.tif", "b.tif", "d.tif"), (b,), phrase="does not exist"),
    ]


def hypsometry_cases() -> list[Case]:
    return [
        Case("hypsometry-csv-and-plot-same-file", C1,
             ("hypsometry", "in.tif", "--csv", "h.png", "--plot", "h.png"),
             (IN,)),
        Case("hypsometry-csv-is-input", C1, ("hypsometry", "in.tif", "--csv", "in.tif", "--overwrite"),
             (IN,)),
        Case("hypsometry-bins-absurd", C3,
             ("hypsometry", "in.tif", "--bins", "100000000000", "--csv", "h.csv"),
             (IN,), phrase="memory"),
        Case("hypsometry-huge-declared-raster", C3, ("hypsometry", "huge.tif", "--csv", "h.csv"),
             (huge_tif("huge.tif"),), phrase="memory"),
        Case("hypsometry-csv-readonly-folder", C2, ("hypsometry", "in.tif", "--csv", "ro/h.csv"),
             (IN, readonly("ro"))),
        Case("hypsometry-plot-missing-folder", C2, ("hypsometry", "in.tif", "--plot", "nowhere/h.png"),
             (IN,)),
        Case("hypsometry-plot-name-too-long", C2,
             ("hypsometry", "in.tif", "--plot", long_name(suffix=".png")),
             (IN,)),
        Case("hypsometry-plot-is-a-folder", C7, ("hypsometry", "in.tif", "--plot", "h.png"),
             (IN, mkdir("h.png")),
             phrase="folder"),
        Case("hypsometry-nan-only-dem", C0, ("hypsometry", "nan.tif", "--csv", "h.csv"),
             (dem("nan.tif", values="nan"),)),
    ]


def glaciate_cases() -> list[Case]:
    run = ("--ela", "150", "--duration", "20")
    table = text("e.csv", "time,ela\n0,150\n1000,150\n")
    return [
        Case("glaciate-ela-table-is-timeline", C1,
             ("glaciate", "in.tif", "out.tif", "--ela", "e.csv", "--timeline", "e.csv", "--duration", "20",
              "--overwrite"), (IN, table)),
        Case("glaciate-ice-is-output", C1, ("glaciate", "in.tif", "out.tif", *run, "--ice", "out.tif"),
             (IN,)),
        Case("glaciate-ice-is-initial-ice", C1,
             ("glaciate", "in.tif", "out.tif", *run, "--ice-thickness", "i.tif", "--ice", "i.tif",
              "--overwrite"),
             (IN, dem("i.tif", values=0.0))),
        Case("glaciate-velocity-is-sliding", C1,
             ("glaciate", "in.tif", "out.tif", *run, "--velocity", "v.tif", "--sliding", "v.tif"), (IN,)),
        Case("glaciate-layers-absurd", C3, ("glaciate", "in.tif", "out.tif", *run, "--layers", "100000000"),
             (IN,),
             phrase="memory"),
        Case("glaciate-duration-1e308", C3,
             ("glaciate", "in.tif", "out.tif", "--ela", "150", "--duration", "1e308"),
             (IN,), timeout=ABSURD),
        Case("glaciate-readonly-folder", C2, ("glaciate", "in.tif", "ro/out.tif", *run),
             (IN, readonly("ro"))),
        Case("glaciate-timeline-missing-folder", C2,
             ("glaciate", "in.tif", "out.tif", *run, "--timeline", "nowhere/t.csv"), (IN,)),
        Case("glaciate-ela-typo", C7, ("glaciate", "in.tif", "out.tif", "--ela", "15O0", "--duration", "20"),
             (IN,),
             phrase="number", absent=("does not exist",)),
        Case("glaciate-malformed-ela-table", C0,
             ("glaciate", "in.tif", "out.tif", "--ela", "e.csv", "--duration", "20"),
             (IN, text("e.csv", "time;ela\n0;150\n"))),
        Case("glaciate-no-duration", C0, ("glaciate", "in.tif", "out.tif", "--ela", "150"), (IN,)),
        Case("glaciate-nan-only-dem", C0, ("glaciate", "nan.tif", "out.tif", *run),
             (dem("nan.tif", values="nan"),)),
    ]


def climate_cases() -> list[Case]:
    return [
        Case("climate-run-uplift-table-is-timeline", C1,
             ("climate-run", "in.tif", "out.tif", *CLIMATE, "--uplift", "out_timeline.csv", "--overwrite"),
             (IN, CHRONOLOGY, text("out_timeline.csv", "age_ka,U_m_per_y\n0,1e-4\n30,1e-4\n"))),
        Case("climate-run-snapshot-is-downstream-mask", C1,
             ("climate-run", "in.tif", "out.tif", *CLIMATE, "--snapshots", "1", "--downstream-mask",
              "out_1ka.tif",
              "--overwrite"), (IN, CHRONOLOGY, dem("out_1ka.tif", values=0.0))),
        Case("climate-run-preview-is-chronology-plot", C1,
             ("climate-run", "in.tif", "out.tif", *CLIMATE, "--preview", "out_chronology.png"),
             (IN, CHRONOLOGY)),
        Case("climate-run-snapshot-outside-the-run", C7,
             ("climate-run", "in.tif", "out.tif", *CLIMATE, "--snapshots", "500"), (IN, CHRONOLOGY),
             phrase="500"),
        Case("climate-run-readonly-folder", C2, ("climate-run", "in.tif", "ro/out.tif", *CLIMATE),
             (IN, CHRONOLOGY, readonly("ro"))),
        Case("climate-run-name-too-long", C2, ("climate-run", "in.tif", long_name(240), *CLIMATE),
             (IN, CHRONOLOGY)),
        Case("climate-run-dt-tiny", C3,
             ("climate-run", "in.tif", "out.tif", "--chronology", "c.csv", "--to", "20", "--dt", "1e-300"),
             (IN, CHRONOLOGY), timeout=ABSURD),
        Case("climate-run-malformed-chronology", C0, ("climate-run", "in.tif", "out.tif", *CLIMATE),
             (IN, text("c.csv", "age_ka,d18o\n0,abc\nfive,3\n"))),
        Case("climate-run-missing-chronology", C0, ("climate-run", "in.tif", "out.tif", *CLIMATE), (IN,)),
        Case("climate-run-from-equals-to", C0,
             ("climate-run", "in.tif", "out.tif", "--chronology", "c.csv", "--from", "2", "--to", "2"),
             (IN, CHRONOLOGY)),
        Case("climate-run-interrupt-hints-resume", C6,
             ("climate-run", "big.tif", "out.tif", "--chronology", "c.csv", "--to", "30", "--dt", "10",
              "--checkpoint-every", "1"), (sample("eroded_utm32n_30m.tif", "big.tif"), CHRONOLOGY),
              exits=(130,),
             phrase="--resume", absent=("--overwrite",), may_create=(".out.tif.checkpoint.npz",),
             interrupt=Interrupt(".out.tif.checkpoint.npz", count=2), timeout=180),
    ]


def terrace_cases() -> list[Case]:
    base = (IN, dem("past_1ka.tif"))
    run = ("compare-terraces", "--present", "in.tif", "--snapshots", "past_1ka.tif", "--auto-river")
    obs = text("obs.csv", OBSERVATIONS)
    return [
        Case("compare-terraces-observations-in-out", C1,
             (*run, "--out", "rep", "--observations", "rep/terraces.csv", "--overwrite"),
             (*base, text("rep/terraces.csv", OBSERVATIONS))),
        Case("compare-terraces-incision-in-out", C1,
             (*run, "--out", "rep", "--incision", "rep/incision.csv", "--overwrite"),
             (*base, text("rep/incision.csv", "from_ka,to_ka,rate_mm_per_ka\n1,0,1\n"))),
        Case("compare-terraces-out-is-a-file", C2, (*run, "--out", "rep", "--observations", "obs.csv"),
             (*base, obs, text("rep", "x"))),
        Case("compare-terraces-out-in-readonly-folder", C2,
             (*run, "--out", "ro/rep", "--observations", "obs.csv"),
             (*base, obs, readonly("ro"))),
        Case("compare-terraces-search-radius-absurd", C3,
             (*run, "--out", "rep", "--observations", "obs.csv", "--search-radius", "1e308"), (*base, obs),
             exits=(0, 2), may_create=("rep", "rep/*"), timeout=ABSURD),
        Case("compare-terraces-glob-matches-nothing", C0,
             ("compare-terraces", "--present", "in.tif", "--snapshots", "nothing_*ka.tif", "--auto-river",
              "--out",
              "rep", "--observations", "obs.csv"), (IN, obs)),
        Case("compare-terraces-observations-missing-column", C0,
             (*run, "--out", "rep", "--observations", "obs.csv"),
             (*base, text("obs.csv", "age_ka,height\n1,5\n"))),
        Case("compare-terraces-missing-present", C0,
             ("compare-terraces", "--present", "nope.tif", "--snapshots", "past_1ka.tif", "--auto-river",
              "--out",
              "rep", "--observations", "obs.csv"), (dem("past_1ka.tif"), obs), phrase="does not exist"),
    ]


def particle_cases() -> list[Case]:
    mask = dem("m.tif", values=1.0)
    return [
        Case("particle-erode-particles-absurd", C3,
             ("particle-erode", "in.tif", "out.tif", "--particles", "1000000000000", "--iterations", "1"),
             (IN,),
             phrase="memory", timeout=ABSURD),
        Case("particle-erode-iterations-absurd", C3,
             ("particle-erode", "in.tif", "out.tif", "--particles", "1", "--iterations", "1000000000000000"),
             (IN,),
             timeout=ABSURD),
        Case("particle-erode-voxels-tiny", C3,
             ("particle-erode", "in.tif", "out.tif", *RAIN, "--representation", "density", "--voxel-size",
              "0.001"),
             (IN,), phrase="memory"),
        Case("particle-erode-interrupt", C4,
             ("particle-erode", "big.tif", "out.tif", "--particles", "300", "--iterations", "100000",
              "--checkpoint-every", "1"), (sample("eroded_utm32n_30m.tif", "big.tif"),), exits=(130,),
             may_create=(".out.tif.checkpoint.npz",), interrupt=Interrupt(".out.tif.checkpoint.npz", count=2),
             timeout=240),
        Case("particle-erode-change-map-is-output", C1,
             ("particle-erode", "in.tif", "out.tif", *RAIN, "--change-map", "out.tif"), (IN,)),
        Case("particle-erode-rain-mask-is-output", C1,
             ("particle-erode", "in.tif", "m.tif", *RAIN, "--rain-mask", "m.tif", "--overwrite"), (IN, mask)),
        Case("particle-erode-source-line-is-paths", C1,
             ("particle-erode", "in.tif", "out.tif", *RAIN, "--source", "line.geojson", "--paths",
              "line.geojson",
              "--overwrite"), (IN, text("line.geojson", LINE))),
        Case("particle-erode-layers-out-is-layers", C1,
             ("particle-erode", "in.tif", "out.tif", *RAIN, "--layers", "layers.tif", "--layers-out",
              "layers.tif",
              "--overwrite"), (IN, dem("layers.tif", bands=2, values=1.0))),
        Case("particle-erode-unknown-preset", C0, ("particle-erode", "in.tif", "out.tif", "--preset", "hail"),
             (IN,)),
        Case("particle-erode-malformed-kinds", C0,
             ("particle-erode", "in.tif", "out.tif", "--kinds", "k.yaml"),
             (IN, text("k.yaml", "kinds: [\n"))),
        Case("particle-erode-malformed-velocity", C0,
             ("particle-erode", "in.tif", "out.tif", *RAIN, "--velocity", "uniform:a,b"), (IN,)),
        Case("particle-erode-readonly-folder", C2, ("particle-erode", "in.tif", "ro/out.tif", *RAIN),
             (IN, readonly("ro"))),
        Case("particle-erode-nan-only-dem", C0, ("particle-erode", "nan.tif", "out.tif", *RAIN),
             (dem("nan.tif", values="nan"),)),
    ]


def landform_cases() -> list[Case]:
    return [
        Case("landforms-spacing-absurd", C3, ("landforms", "in.tif", "--out", "lf", "--spacing", "1e-9"),
             (IN,),
             timeout=ABSURD),
        Case("landforms-half-width-absurd", C3,
             ("landforms", "in.tif", "--out", "lf", "--half-width", "1e308"),
             (IN,), exits=(0, 2), may_create=("lf", "lf/*"), timeout=ABSURD),
        Case("landforms-out-is-a-file", C2, ("landforms", "in.tif", "--out", "lf"), (IN, text("lf", "x"))),
        Case("landforms-out-in-readonly-folder", C2, ("landforms", "in.tif", "--out", "ro/lf"),
             (IN, readonly("ro"))),
        Case("landforms-before-is-an-output", C1,
             ("landforms", "in.tif", "--out", ".", "--before", "landforms.png", "--overwrite"),
             (IN, dem("landforms.png"))),
        Case("landforms-missing-before", C0, ("landforms", "in.tif", "--out", "lf", "--before", "nope.tif"),
             (IN,),
             phrase="does not exist"),
        Case("landforms-nan-only-dem", C0, ("landforms", "nan.tif", "--out", "lf"),
             (dem("nan.tif", values="nan"),)),
    ]


def sandstone_cases() -> list[Case]:
    scene = text("scene.yaml", SCENE)
    return [
        Case("sandstone-unknown-preset", C0, ("sandstone", "pyramid", "out")),
        Case("sandstone-dem-without-extrude", C0, ("sandstone", "in.tif", "out"), (IN,)),
        Case("sandstone-malformed-scene", C0, ("sandstone", "scene.yaml", "out"),
             (text("scene.yaml", "shape: {box: [\n"),)),
        Case("sandstone-negative-frames", C0, ("sandstone", "scene.yaml", "out", "--frames", "-1"), (scene,)),
        Case("sandstone-out-is-a-file", C2, ("sandstone", "scene.yaml", "out", "--frames", "1"),
             (scene, text("out", "x"))),
        Case("sandstone-out-in-readonly-folder", C2, ("sandstone", "scene.yaml", "ro/out", "--frames", "1"),
             (scene, readonly("ro"))),
        Case("sandstone-particles-absurd", C3, ("sandstone", "arch", "out", "--particles", "1000000000000",
                                                "--frames", "1"), phrase="memory"),
        Case("sandstone-scene-is-run-json", C1,
             ("sandstone", "out/run.json", "out", "--frames", "1", "--overwrite"),
             (text("out/run.json", SCENE),)),
        Case("sandstone-mesh-is-particles", C1,
             ("sandstone", "scene.yaml", "out", "--frames", "1", "--mesh", "out/particles.ply"), (scene,)),
        Case("sandstone-mesh-is-a-folder", C7,
             ("sandstone", "scene.yaml", "out", "--frames", "1", "--mesh", "m.ply"),
             (scene, mkdir("m.ply")), phrase="folder"),
    ]


def pipe(*steps: dict, **extra: object) -> dict:
    """A pipeline spec of ``steps``."""
    return {"version": 1, **extra, "steps": list(steps)}


def step(name: str, run: str, *args: str, **options: object) -> dict:
    entry: dict = {"name": name, "run": run, "args": list(args)}
    if options:
        entry["options"] = {key.replace("_", "-"): value for key, value in options.items()}
    return entry


SPEC_DEM = dem("spec/dem.tif")
#: YAML whose aliases expand to 9⁹ items ("billion laughs").
ALIAS_BOMB = ("a: &a [x, x, x, x, x, x, x, x, x]\n"
              + "".join(f"{c}: &{c} [{', '.join(['*' + b] * 9)}]\n" for b, c in zip("abcdefgh", "bcdefghi",
                                                                                    strict=True))
              + "version: 1\nsteps: *i\n")
CONVERT = step("copy", "convert", "dem.tif", "out.tif")


def pipeline_cases() -> list[Case]:
    run = ("pipeline", "run", "spec/p.yaml")
    victim = dem("victim.tif")
    return [
        Case("pipeline-output-in-parent-folder", C8, run,
             (SPEC_DEM, spec("spec/p.yaml", pipe(step("copy", "convert", "dem.tif", "../escape.tif"))))),
        Case("pipeline-output-absolute-path", C8, run,
             (SPEC_DEM,
              spec("spec/p.yaml",
                   lambda f: pipe(step("copy", "convert", "dem.tif", str(f / "escape.tif")))))),
        Case("pipeline-workdir-outside", C8, run,
             (SPEC_DEM, mkdir("outside"),
              spec("spec/p.yaml", pipe(step("copy", "convert", "../spec/dem.tif",
                                                                       "out.tif"), workdir="../outside")))),
        Case("pipeline-var-escapes", C8, (*run, "--var", "out=../escape.tif"),
             (SPEC_DEM,
              spec("spec/p.yaml",
                   pipe(step("copy", "convert", "dem.tif", "${out}"), vars={"out": "out.tif"})))),
        Case("pipeline-input-outside", C8, run,
             (dem("outside/dem.tif"),
              spec("spec/p.yaml", pipe(step("copy", "convert", "../outside/dem.tif", "out.tif"))))),
        Case("pipeline-params-raster-outside", C8, run,
             (SPEC_DEM, dem("outside/k.tif", values=1e-5), text("spec/params.yaml", "K: ../outside/k.tif\n"),
              spec("spec/p.yaml",
                   pipe(step("e", "erode", "dem.tif", "out.tif", steps=1, params="params.yaml"))))),
        Case("pipeline-preview-outside", C8, run,
             (SPEC_DEM,
              spec("spec/p.yaml", pipe(step("copy", "convert", "dem.tif", "out.tif", preview="../p.png"))))),
        Case("pipeline-symlink-out-of-workdir", C8, run,
             (SPEC_DEM, victim, symlink("spec/link.tif", "../victim.tif"),
              spec("spec/p.yaml", pipe(step("copy", "convert", "dem.tif", "link.tif", overwrite=True))))),
        Case("pipeline-overwrite-a-file-it-did-not-write", C8, run,
             (SPEC_DEM, dem("spec/precious.tif", values=7.0),
              spec("spec/p.yaml", pipe(step("copy", "convert", "dem.tif", "precious.tif", overwrite=True))))),
        Case("pipeline-python-tag", C0, run,
             (SPEC_DEM,
              text("spec/p.yaml", "version: 1\nsteps: !!python/object/apply:os.system ['touch pwned']\n"))),
        Case("pipeline-alias-bomb", C0, run,
             (SPEC_DEM, text("spec/p.yaml", ALIAS_BOMB))),
        Case("pipeline-malformed-yaml", C0, run, (SPEC_DEM, text("spec/p.yaml", "version: 1\nsteps: [\n"))),
        Case("pipeline-unknown-subcommand", C0, run,
             (SPEC_DEM, spec("spec/p.yaml", pipe(step("x", "melt", "dem.tif"))))),
        Case("pipeline-missing-input", C0, run,
             (spec("spec/p.yaml", pipe(step("copy", "convert", "nope.tif", "out.tif"))),)),
        Case("pipeline-two-steps-same-output", C1, run,
             (SPEC_DEM, spec("spec/p.yaml", pipe(CONVERT, step("again", "convert", "dem.tif", "out.tif"))))),
        Case("pipeline-step-output-is-its-input", C1, run,
             (SPEC_DEM,
              spec("spec/p.yaml", pipe(step("copy", "convert", "dem.tif", "dem.tif", overwrite=True))))),
        Case("pipeline-missing-spec", C0, run, phrase="does not exist"),
    ]


def ensemble_spec(*steps: dict, sweep: dict | None = None, **extra: object) -> dict:
    return {**pipe(*steps, **extra), "sweep": sweep or {"e.K": [1e-5, 2e-5]}}


def ensemble_cases() -> list[Case]:
    run = ("ensemble", "spec/ens.yaml", "out")
    erode = step("e", "erode", "dem.tif", "past.tif", steps=1)
    return [
        Case("ensemble-output-outside-member", C8, run,
             (SPEC_DEM,
              spec("spec/ens.yaml", ensemble_spec(step("e", "erode", "dem.tif", "../../../escape.tif",
                                                                 steps=1))))),
        Case("ensemble-output-absolute-path", C8, run,
             (SPEC_DEM,
              spec("spec/ens.yaml", lambda f: ensemble_spec(step("e", "erode", "dem.tif", str(f / "x.tif"),
                                                                           steps=1))))),
        Case("ensemble-var-escapes", C8, (*run, "--var", "out=../../../escape.tif"),
             (SPEC_DEM, spec("spec/ens.yaml", ensemble_spec(step("e", "erode", "dem.tif", "${out}", steps=1),
                                                            vars={"out": "past.tif"})))),
        Case("ensemble-input-outside", C8, run,
             (dem("outside/dem.tif"),
              spec("spec/ens.yaml", ensemble_spec(step("e", "erode", "../outside/dem.tif",
                                                                               "past.tif", steps=1))))),
        Case("ensemble-params-raster-outside", C8, run,
             (SPEC_DEM, dem("outside/k.tif", values=1e-5), text("spec/params.yaml", "K: ../outside/k.tif\n"),
              spec("spec/ens.yaml", ensemble_spec(step("e", "erode", "dem.tif", "past.tif", steps=1,
                                                       params="params.yaml"), sweep={"e.K-d": [0.5, 1.0]})))),
        Case("ensemble-swept-input-outside", C8, run,
             (SPEC_DEM, dem("outside/k.tif", values=1e-5),
              spec("spec/ens.yaml", ensemble_spec(erode, sweep={"e.K": ["../outside/k.tif", "1e-5"]})))),
        Case("ensemble-members-absurd", C3, (*run, "--members", "1000000000000"),
             (SPEC_DEM,
              spec("spec/ens.yaml", ensemble_spec(erode, sweep={"e.K": {"uniform": [1e-5, 2e-5]}}))),
             timeout=ABSURD),
        Case("ensemble-leaves-no-scratch-space", C6, (*run, "--workers", "1"),
             (SPEC_DEM, spec("spec/ens.yaml", ensemble_spec(erode))), exits=(0,), may_create=("out", "out/*"),
             timeout=180),
        Case("ensemble-malformed-spec", C0, run, (SPEC_DEM, text("spec/ens.yaml", "version: 1\nsweep: {\n"))),
        Case("ensemble-unknown-sweep-key", C0, run,
             (SPEC_DEM, spec("spec/ens.yaml", ensemble_spec(erode, sweep={"e.lava": [1, 2]})))),
        Case("ensemble-out-is-a-file", C2, run,
             (SPEC_DEM, spec("spec/ens.yaml", ensemble_spec(erode)), text("out", "x"))),
        Case("ensemble-spec-is-its-record", C1, ("ensemble", "out/ensemble.json", "out", "--overwrite"),
             (dem("out/dem.tif"), spec("out/ensemble.json", ensemble_spec(erode)))),
    ]


def report_cases() -> list[Case]:
    run = (mkdir("run"), dem("run/out.tif"))
    return [
        Case("report-output-is-the-reported-raster", C1,
             ("report", ".", "--climate-run", "out.tif", "-o", "out.tif", "--overwrite"), (dem("out.tif"),)),
        Case("report-missing-folder", C2, ("report", "run", "-o", "nowhere/r.html"), run),
        Case("report-readonly-folder", C2, ("report", "run", "-o", "ro/r.html"), (*run, readonly("ro"))),
        Case("report-name-too-long", C2, ("report", "run", "-o", long_name(suffix=".html")), run),
        Case("report-output-is-a-folder", C7, ("report", "run", "-o", "r.html"), (*run, mkdir("r.html")),
             phrase="folder"),
        Case("report-missing-run-folder", C0, ("report", "nope"), phrase="does not exist"),
        Case("report-existing-output", C0, ("report", "run"), (*run, text("run/report.html", "precious")),
             phrase="--overwrite"),
    ]


def georef_cases() -> list[Case]:
    """Georeferencing assigned to inputs (--crs, --cell-size, --nodata) and --snapshots-nc,
    refused before any work (issue 51)."""
    exr = exr_header("dem.exr")
    return [
        Case("info-crs-unparsable", C0, ("info", "in.tif", "--crs", "EPSG:999999"), (IN,), phrase="CRS"),
        Case("info-crs-garbage", C0, ("info", "in.tif", "--crs", "not a crs"), (IN,), phrase="pyproj"),
        Case("info-cell-size-zero", C0, ("info", "dem.exr", "--cell-size", "0"), (exr,), phrase="> 0"),
        Case("flow-cell-size-negative", C0, ("flow", "dem.exr", "q.tif", "--cell-size", "-30"), (exr,),
             phrase="> 0"),
        Case("convert-crs-of-another-input", C0, ("convert", "in.tif", "out.tif", "--crs", "EPSG:4326"),
             (IN,), phrase="already has a CRS"),
        Case("erode-crs-of-another-input", C0, ("erode", "in.tif", "out.tif", "--steps", "1", "--crs",
                                                "EPSG:32633"), (IN,), phrase="already has a CRS"),
        Case("preview-cell-size-of-another-input", C0, ("preview", "in.tif", "p.png", "--cell-size", "10"),
             (IN,), phrase="already has a geotransform"),
        Case("convert-crs-same-as-input", C0, ("convert", "in.tif", "out.tif", "--crs", "EPSG:32632"), (IN,),
             exits=(0,), may_create=OUTS),
        Case("erode-snapshots-nc-without-snapshots", C0,
             ("erode", "in.tif", "out.tif", "--steps", "2", "--snapshots-nc", "s.nc"), (IN,),
             phrase="--snapshot-every"),
        Case("erode-snapshots-nc-not-nc", C0,
             ("erode", "in.tif", "out.tif", "--steps", "2", "--dt", "100", "--snapshot-every", "100",
              "--snapshots-nc", "s.tif"), (IN,), phrase=".nc"),
        Case("climate-snapshots-nc-without-snapshots", C0,
             ("climate-run", "in.tif", "out.tif", *CLIMATE, "--snapshots-nc", "s.nc"), (IN, CHRONOLOGY),
             phrase="--snapshots"),
    ]


def all_cases() -> list[Case]:
    """Every case, by subcommand."""
    cases = [*info_cases(), *convert_cases(), *preview_cases(), *synth_cases(), *flow_cases(), *erode_cases(),
             *unerode_cases(), *diff_cases(), *hypsometry_cases(), *glaciate_cases(), *climate_cases(),
             *terrace_cases(), *particle_cases(), *landform_cases(), *sandstone_cases(), *ensemble_cases(),
             *report_cases(), *pipeline_cases(), *georef_cases()]
    names = [case.name for case in cases]
    assert len(names) == len(set(names)), "two cases share a name"
    return cases


CASES = all_cases()
