"""Flow routing: depression handling, receivers, order and accumulation (000 Eq. 5–6)."""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Literal

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.hydro import kernels
from unerode_cli.hydro.fields import flat_field
from unerode_cli.hydro.outlets import require_outlets

Method = Literal["mfd", "d8"]
METHODS: tuple[str, ...] = ("mfd", "d8")


class _Scratch(threading.local):
    """Work arrays kept between calls, one set per thread."""

    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}


_SCRATCH = _Scratch()


def scratch(name: str, shape: tuple[int, ...], dtype: type) -> np.ndarray:
    """A work array (any content) kept for the next call that asks for ``name`` in this
    thread with the same shape and dtype, e.g. in every time step on one grid: a fresh
    array of tens of MB costs more in page faults than the kernels spend filling it. Only
    the latest array of each name is kept. Callers must not hand the array out."""
    arrays = _SCRATCH.arrays
    array = arrays.get(name)
    if array is None or array.shape != shape or array.dtype != dtype:
        arrays.pop(name, None)
        array = np.empty(shape, dtype=dtype)
        arrays[name] = array
    return array


def release_scratch(prefix: str = "") -> None:
    """Drop this thread's work arrays whose names start with ``prefix`` (all by default: a
    one-shot job that has routed for the last time; ``"flood."``: the priority flood's)."""
    arrays = _SCRATCH.arrays
    for name in [name for name in arrays if name.startswith(prefix)]:
        del arrays[name]


@dataclass(frozen=True)
class Routing:
    """How water flows over one surface.

    Receivers are read off ``filled``: the receivers of a valid non-outlet cell are its
    strictly lower neighbours (all of them with ``"mfd"``, the steepest one with ``"d8"``).

    Attributes:
        grid: the grid routed on.
        method: ``"mfd"`` (multiple flow directions, 000 Eq. 6) or ``"d8"`` (steepest descent).
        filled: float64[ny, nx] routing surface (m): the elevation after priority-flood+ε,
            equal to it outside depressions; +inf on nodata.
        outlets: bool[ny, nx] sinks of the flow (the mask routed to, not a copy, when it lies
            inside the domain).
        order: flat indices of all valid cells sorted by descending routing surface,
            so every cell comes before its receivers (000 Algorithm 1); int32 below 2^31
            cells (half the memory traffic of the serial sweeps that read it), else int64.
    """

    grid: Grid
    method: str
    filled: np.ndarray
    outlets: np.ndarray
    order: np.ndarray

    @property
    def single(self) -> bool:
        """Whether each cell has a single receiver (D8)."""
        return self.method == "d8"

    def receivers(self) -> np.ndarray:
        """int64[ny, nx] flat index of the steepest receiver (the D8 receiver; with MFD the
        neighbour of largest fraction), -1 for outlets and nodata cells."""
        grid = self.grid
        receivers = kernels.steepest_receiver(self.filled, self.outlets, grid.dx, grid.dy)
        return receivers.reshape(grid.shape)

    def fractions(self) -> np.ndarray:
        """float64[ny, nx, 8] fraction of each cell's flow sent to each neighbour, neighbours
        in row-major order of offsets (-1,-1), (-1,0), (-1,1), (0,-1), (0,1), (1,-1), (1,0),
        (1,1); 0 for non-receivers, outlets and nodata (000 Eq. 6)."""
        grid = self.grid
        fractions = kernels.fraction_field(self.filled, self.outlets, grid.dx, grid.dy, self.single)
        return fractions.reshape(*grid.shape, 8)


def route(elevation: np.ndarray, grid: Grid, outlets: np.ndarray, method: Method = "mfd",
          filled: np.ndarray | None = None) -> Routing:
    """Route flow over ``elevation`` (m) towards ``outlets``.

    Depressions are handled by priority-flood+ε (Barnes et al. 2014) on a copy, so every valid
    non-outlet cell has at least one strictly lower valid neighbour on the routing surface.
    The copy is a new array, or ``filled`` (float64[ny, nx], C-contiguous) when given, which
    may be ``elevation`` itself: a one-shot caller that needs the elevation no more saves a
    grid of float64 (the routing surface replaces the elevation, +inf on nodata).

    Raises:
        ValueError: unknown method, shape mismatch, no outlet, non-finite elevation in the
            domain, or valid cells that cannot reach any outlet (an island without outlet).
    """
    if method not in METHODS:
        raise ValueError(f"routing method must be one of {', '.join(METHODS)}, got {method!r}")
    valid = grid.valid
    z, outlets = flood_inputs(elevation, grid, outlets)
    n = z.size
    index = np.int32 if n < 2**31 else np.int64  # cell indices in the work arrays
    if filled is None:
        filled = np.empty(grid.shape, dtype=np.float64)
    elif filled.shape != grid.shape or filled.dtype != np.float64 or not filled.flags.c_contiguous:
        raise ValueError("the routing surface must be a C-contiguous float64 array of the grid's shape")
    descending = np.empty(n, dtype=index)
    count = kernels.flood_into(
        z,
        valid,
        outlets,
        filled.ravel(),
        descending,
        scratch("flood.closed", (n,), np.bool_),
        scratch("flood.first", (kernels.bucket_count(n),), index),
        scratch("flood.following", (n,), index),
        scratch("flood.heap", (n, 2), np.float64),
        scratch("flood.pit", (n,), index),
    )
    order = descending[n - count :]
    require_all_reached(valid, count)
    return Routing(grid, method, filled, outlets, order)


def flood_inputs(elevation: np.ndarray, grid: Grid, outlets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The checked inputs of a priority flood: (elevation as contiguous float64, outlets as
    contiguous bool inside the domain: the mask given itself when it is one and has no outlet
    outside the domain, so that a routing holds no copy of it). Raises ValueError for a shape
    mismatch, no outlet or a non-finite elevation in the domain."""
    if elevation.shape != grid.shape or outlets.shape != grid.shape:
        raise ValueError(
            f"elevation {elevation.shape} and outlets {outlets.shape} must have the grid's shape {grid.shape}"
        )
    outlets = np.ascontiguousarray(outlets, dtype=bool)
    if np.any(outlets > grid.valid):
        outlets = outlets & grid.valid
    require_outlets(outlets)
    z = np.ascontiguousarray(elevation, dtype=np.float64)
    if not np.isfinite(z).all() and not np.isfinite(z[grid.valid]).all():
        raise ValueError("the elevation has non-finite values inside the domain (not nodata)")
    return z, outlets


def require_all_reached(valid: np.ndarray, count: int) -> None:
    """Raise ValueError when a flood from the outlets reached only ``count`` of the valid cells."""
    unreached = int(np.count_nonzero(valid)) - count
    if unreached:
        raise ValueError(
            f"{unreached} valid cells cannot drain to any outlet: add outlets in every "
            "separate part of the domain"
        )


def fingerprint(values: np.ndarray) -> tuple[tuple[int, ...], int]:
    """(shape, 64-bit fingerprint of the float64 bits) of ``values`` (elevations, m; NaN
    included): equal for the same values bit for bit; a change of one cell always changes it,
    any other change but for a chance of about 2⁻⁶⁴ (``kernels.fingerprint_words``). Takes
    one pass at memory speed and no copy of the grid."""
    words = np.ascontiguousarray(values, dtype=np.float64).reshape(-1).view(np.uint64)
    return tuple(values.shape), int(kernels.fingerprint_words(words))


def accumulate(routing: Routing, source: float | np.ndarray) -> np.ndarray:
    """Upstream integral of ``source`` × cell area over the flow network (000 Eq. 5).

    With ``source`` the precipitation p (m/y, scalar or float[ny, nx]) this is the discharge Q
    (m³/y); with 1 it is the drainage area (m²). Nodata cells carry no flow (0).
    """
    grid = routing.grid
    acc = np.zeros(grid.shape, dtype=np.float64)
    kernels.accumulate_into(
        routing.filled, routing.outlets, routing.order, grid.dx, grid.dy, routing.single,
        cell_sources(grid, source), acc.ravel(),
    )
    return acc


def cell_sources(grid: Grid, rate: float | np.ndarray) -> np.ndarray:
    """What each cell adds to the flow: ``rate`` (per m², e.g. precipitation in m/y; scalar
    or float[ny, nx]) × cell area, as the flat field the kernels read (float64[1] for a
    scalar)."""
    return flat_field(rate, grid.shape, "source") * grid.cell_area


def drainage_area(routing: Routing) -> np.ndarray:
    """Upstream area of every cell (m²), the cell itself included; 0 on nodata."""
    return accumulate(routing, 1.0)
