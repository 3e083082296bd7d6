"""Flow routing: depression handling, receivers, order and accumulation (000 Eq. 5–6)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.hydro import kernels
from unerode_cli.hydro.fields import flat_field
from unerode_cli.hydro.outlets import require_outlets

Method = Literal["mfd", "d8"]
METHODS: tuple[str, ...] = ("mfd", "d8")


@dataclass(frozen=True)
class Routing:
    """How water flows over one surface.

    Attributes:
        grid: the grid routed on.
        method: ``"mfd"`` (multiple flow directions, 000 Eq. 6) or ``"d8"`` (steepest descent).
        filled: float64[ny, nx] routing surface (m): the elevation after priority-flood+ε,
            equal to it outside depressions; nodata cells keep their input value.
        outlets: bool[ny, nx] sinks of the flow.
        weights: float64[ny*nx, 8] fraction of a cell's flow sent to each neighbour, the
            neighbours in row-major order of offsets (-1,-1), (-1,0), (-1,1), (0,-1), (0,1),
            (1,-1), (1,0), (1,1); a neighbour is a receiver iff its weight is > 0.
        order: int64 flat indices of all valid cells, every cell before its receivers
            (descending order of the routing surface along each flow path).
    """

    grid: Grid
    method: str
    filled: np.ndarray
    outlets: np.ndarray
    weights: np.ndarray
    order: np.ndarray

    def receivers(self) -> np.ndarray:
        """int64[ny, nx] flat index of the steepest receiver (the D8 receiver; with MFD the
        neighbour of largest weight), -1 for outlets and nodata cells."""
        ny, nx = self.grid.shape
        return kernels.steepest_receiver(self.weights, nx).reshape(ny, nx)


def route(
    elevation: np.ndarray, grid: Grid, outlets: np.ndarray, method: Method = "mfd"
) -> Routing:
    """Route flow over ``elevation`` (m) towards ``outlets``; the elevation is not modified.

    Depressions are handled by priority-flood+ε on a copy (Barnes et al. 2014), so every valid
    non-outlet cell has at least one strictly lower valid neighbour on the routing surface.

    Raises:
        ValueError: unknown method, shape mismatch, no outlet, non-finite elevation in the
            domain, or valid cells that cannot reach any outlet (an island without outlet).
    """
    if method not in METHODS:
        raise ValueError(f"routing method must be one of {', '.join(METHODS)}, got {method!r}")
    valid = grid.valid
    if elevation.shape != grid.shape or outlets.shape != grid.shape:
        raise ValueError(
            f"elevation {elevation.shape} and outlets {outlets.shape} must have the grid's "
            f"shape {grid.shape}"
        )
    outlets = np.ascontiguousarray(outlets, dtype=bool) & valid
    require_outlets(outlets)
    z = np.ascontiguousarray(elevation, dtype=np.float64)
    if not np.isfinite(z).all() and not np.isfinite(z[valid]).all():
        raise ValueError("the elevation has non-finite values inside the domain (not nodata)")
    filled, reached = kernels.priority_flood_epsilon(z, valid, outlets)
    unreached = int(np.count_nonzero(valid)) - reached
    if unreached:
        raise ValueError(
            f"{unreached} valid cells cannot drain to any outlet: add outlets in every "
            "separate part of the domain"
        )
    weights = kernels.flow_weights(filled, valid, outlets, grid.dx, grid.dy, method == "d8")
    order = kernels.topological_order(weights, valid, outlets)
    return Routing(grid, method, filled, outlets, weights, order)


def accumulate(routing: Routing, source: float | np.ndarray) -> np.ndarray:
    """Upstream integral of ``source`` × cell area over the flow network (000 Eq. 5).

    With ``source`` the precipitation p (m/y, scalar or float[ny, nx]) this is the discharge Q
    (m³/y); with 1 it is the drainage area (m²). Nodata cells carry no flow (0).
    """
    grid = routing.grid
    src = flat_field(source, grid.shape, "source") * grid.cell_area
    acc = kernels.accumulate_flow(routing.order, routing.weights, grid.shape[1], src)
    return acc.reshape(grid.shape)


def drainage_area(routing: Routing) -> np.ndarray:
    """Upstream area of every cell (m²), the cell itself included; 0 on nodata."""
    return accumulate(routing, 1.0)
