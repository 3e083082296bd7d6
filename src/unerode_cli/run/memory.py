"""Memory estimates checked before allocating: a job's plan adds up the bytes of the arrays its
run will hold at once and refuses (InputError, exit code 2) what the machine cannot hold.

The memory available is the kernel's ``MemAvailable`` (``/proc/meminfo``: free memory plus
what the page cache can give back), or ``os.sysconf``'s free pages where there is no
``/proc/meminfo``; inside a cgroup (v2) with a memory limit, no more than the limit minus its
current use. The environment variable ``UNERODE_MEMORY_GIB`` lowers it to that many GiB (a
share of a machine used by others, or tests).

Importing this module registers :func:`check_fits` with ``io.rasters`` (which may not import
``run``), so that every ``read_terrain`` is checked against the header's cells before any cell
is read; jobs add their own estimates (resampled grids, bins, layers, particles) in ``plan()``.
"""

from __future__ import annotations

import math
import os

from unerode_cli.errors import InputError
from unerode_cli.io import rasters
from unerode_cli.io.system_memory import memory_available, resident_bytes

GIB = float(2**30)
#: Environment variable: at most this many GiB are taken to be available.
MEMORY_ENV = "UNERODE_MEMORY_GIB"

def gib(nbytes: float) -> str:
    """``nbytes`` in GiB, for a sentence: "3.2 GiB", "1,490.1 GiB", "7.5e+295 GiB", "0.0012 GiB"."""
    value = nbytes / GIB
    return f"{value:,.1f} GiB" if 0.1 <= value < 1e7 or value == 0 else f"{value:.2g} GiB"


def available_bytes() -> float:
    """Bytes a job may allocate now (see the module docstring)."""
    free = memory_available()
    cap = os.environ.get(MEMORY_ENV)
    if cap:
        try:
            cap_gib = float(cap)
        except ValueError:
            cap_gib = float("nan")
        if not cap_gib > 0:
            raise InputError(f"the environment variable {MEMORY_ENV} must be a positive number of GiB, "
                             f"got '{cap}'.")
        free = min(free, cap_gib * GIB)
    return float(free)


def headroom_bytes() -> float:
    """Bytes a running job may still allocate: the memory available, and under a cap
    (``UNERODE_MEMORY_GIB``, the whole share of the job) the cap less what the process holds."""
    free = available_bytes()
    if os.environ.get(MEMORY_ENV):
        free = min(free, float(os.environ[MEMORY_ENV]) * GIB - resident_bytes())
    return free


def check_fits(nbytes: float, what: str, change: str) -> None:
    """Refuse (InputError) an estimate of ``nbytes`` bytes above the memory available.

    ``what`` names what needs them ("reading dem.tif (200,000 × 200,000 cells)"), ``change``
    says what to change ("crop it first with convert --crop"); the sentence gives both amounts
    in GiB."""
    free = available_bytes()
    if not nbytes <= free:  # NaN included
        need = (f"about {gib(nbytes)} of memory" if math.isfinite(nbytes)
                else "more memory than can be counted")
        raise InputError(f"{what} needs {need}, more than the {gib(free)} available; {change}.")


def check_read(header: rasters.RasterHeader, extra_per_cell: float = 0.0, extra: float = 0.0,
               change: str = "") -> None:
    """Refuse reading every cell of ``header``'s raster when that (``read_bytes_per_cell``),
    plus ``extra_per_cell`` bytes per cell and ``extra`` bytes more, does not fit."""
    nbytes = float(header.cells) * (header.read_bytes_per_cell + extra_per_cell) + extra
    check_fits(nbytes, f"reading {header.path} ({header.size_text()})",
               change or "crop it to the area needed first (convert --crop reads only that window), "
               "or use a machine with more memory")


# every raster read (io.rasters.read_terrain) is checked against the memory available
rasters.set_memory_check(check_fits)


#: Resident bytes of the interpreter with its libraries and compiled kernels, before any grid.
BASE_BYTES = 0.3 * GIB
#: Peak resident bytes per cell of a run beyond :data:`BASE_BYTES`, measured at 8192² by
#: ``bench/memory.py`` (docs/memory.md) and rounded up: the grids it holds at once (elevations,
#: routing, fluxes, work arrays), the fluvial process in its dearest setting (MFD, K_d > 0). An
#: implicit erode takes its lean layout where the faster one does not fit (``run.registry``),
#: so its least is what must fit (59 measured beyond the base, 4 more where a float64 DEM that
#: float32 cannot hold keeps a float64 start: ``jobs.erode.start``); explicit steps (unerode,
#: erode --scheme explicit) hold their fluxes and work arrays whole; climate-run (not measured
#: at 8192²) is given the explicit step's bytes with a margin for its sea-level and climate
#: grids.
COMMAND_BYTES_PER_CELL = {
    "flow": 32,
    "erode": 68,
    "erode explicit": 100,
    "unerode": 100,
    "climate-run": 120,
}


def check_command(command: str, header: rasters.RasterHeader, change: str = "", kind: str = "") -> float:
    """Refuse (InputError, before any cell is read) a run of ``command`` on ``header``'s
    raster whose estimated peak, :data:`BASE_BYTES` + cells × :data:`COMMAND_BYTES_PER_CELL`
    (of ``"command kind"`` when ``kind`` is given), does not fit in the memory available;
    returns the estimate (bytes)."""
    per_cell = COMMAND_BYTES_PER_CELL[f"{command} {kind}" if kind else command]
    nbytes = BASE_BYTES + float(header.cells) * per_cell
    check_fits(nbytes, f"{command} on {header.path} ({header.size_text()})",
               change or "crop it to the area needed first (convert --crop reads only that window) or "
               "coarsen it (convert --cell-size), or use a machine with more memory")
    return nbytes
