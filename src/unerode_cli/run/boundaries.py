"""Boundary conditions of a run: outlets and Dirichlet (fixed-elevation) nodes, and the base
level each boundary node follows through a climate run (DESIGN §7)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unerode_cli.climate.chronology import Series
from unerode_cli.errors import InputError
from unerode_cli.hydro.outlets import outlet_mask
from unerode_cli.io.chronology_files import read_age_table
from unerode_cli.io.grid_rasters import load_on_grid
from unerode_cli.io.terrain import Terrain
from unerode_cli.run.nesting import NodeLevels

#: What a boundary node that is not sea can follow (``--edge-base``), besides a table file.
EDGE_BASES = ("fixed", "uplift")
#: ``--edge-base`` of a nested run: follow the surface of its coarse run (``--inflow-from``).
COARSE = "coarse"


@dataclass(frozen=True)
class Boundaries:
    """Where flow leaves the domain.

    Attributes:
        edges: draining domain edges ("all", "none" or a comma list of N, E, S, W).
        sea_level: cells at or below it (m) are outlets (None: no sea).
        dirichlet: bool[ny, nx] fixed-elevation nodes, or None.
    """

    edges: str = "all"
    sea_level: float | None = None
    dirichlet: np.ndarray | None = None

    def outlets(self, elevation: np.ndarray, terrain: Terrain) -> np.ndarray:
        """bool[ny, nx] outlet mask for the current ``elevation`` (m)."""
        try:
            return outlet_mask(terrain.grid, self.edges, dirichlet=self.dirichlet,
                               elevation=elevation, sea_level=self.sea_level)
        except ValueError as exc:
            raise InputError(f"{exc}.") from None


def boundaries_from_options(
    terrain: Terrain, edges: str, sea_level: float | None, dirichlet: Path | None,
    fixed: np.ndarray | None = None,
) -> Boundaries:
    """Build and check the boundaries given on the command line (exit 2 when there is no outlet);
    ``fixed`` (bool[ny, nx], optional) adds fixed-elevation nodes to those of ``dirichlet``."""
    mask = fixed
    if dirichlet is not None:
        layer = load_on_grid(dirichlet, terrain, "Dirichlet mask")
        given = np.isfinite(layer) & (layer != 0)
        mask = given if fixed is None else given | fixed
    if sea_level is not None and not np.isfinite(sea_level):
        raise InputError("--sea-level must be a finite elevation in metres.")
    bounds = Boundaries(edges, sea_level, mask)
    if not bounds.outlets(terrain.elevation, terrain).any():
        raise InputError(
            "the DEM has no outlet at all: choose draining edges with --outlets, a --sea-level, "
            "a --dirichlet mask, or use a DEM with nodata borders."
        )
    return bounds


@dataclass(frozen=True)
class BaseLevels:
    """The boundary nodes of a climate run and the base level each one follows.

    Only sea follows sea level: the coast cells and the other boundary nodes at or below the
    sea level of the start age move by sea(t) − sea(start). Every other boundary node (draining
    edges, nodata borders, Dirichlet nodes) follows ``edge_base``: "fixed" keeps its elevation,
    "uplift" rises by U·dt each step as the interior does (U·t in all, t in years, negative
    backward), "table" moves by T(t) − T(start) of ``table``, so each node keeps its own shape.

    Attributes:
        edges: draining domain edges of ``--outlets`` ("all", "none" or e.g. "N,S").
        coast: bool[ny, nx] cells of the coast edges (``--coast``).
        sea: bool[ny, nx] the other boundary nodes at or below the start's sea level.
        edge: bool[ny, nx] the remaining boundary nodes.
        edge_base: "fixed", "uplift", "table" or "coarse".
        table: the base level (m) by age (ka) with "table", else None.
        start_ka: age of the input DEM (ka).
        node_levels: with "coarse", the levels of the ``edge`` nodes (in row-major order) by age.
    """

    edges: str
    coast: np.ndarray
    sea: np.ndarray
    edge: np.ndarray
    edge_base: str = "fixed"
    table: Series | None = None
    start_ka: float = 0.0
    node_levels: NodeLevels | None = None

    @property
    def nodes(self) -> np.ndarray:
        """bool[ny, nx] every boundary node."""
        return self.coast | self.sea | self.edge

    def boundaries(self, sea_level: float | None) -> Boundaries:
        """The outlets of a step: the boundary nodes, and the cells at or below ``sea_level``
        (m; None: no sea outlets)."""
        return Boundaries(self.edges, sea_level, self.nodes)

    def set_levels(self, h: np.ndarray, start: np.ndarray, sea_change: float, age_ka: float,
                   uplift: float | np.ndarray, dt: float) -> None:
        """Set the boundary nodes of ``h`` (m, in place; its nodes at their level at the start of
        the step) to their base level at ``age_ka`` (ka), the end of a step of ``dt`` years.

        Args:
            start: elevation of the input DEM (m).
            sea_change: sea level at ``age_ka`` minus that at the start age (m).
            uplift: U of the step (m/y, a number or float64[ny, nx]).
        """
        sea = self.coast | self.sea
        h[sea] = start[sea] + sea_change
        if self.edge_base == "uplift":
            h[self.edge] += np.broadcast_to(uplift, h.shape)[self.edge] * dt
        elif self.table is not None:
            h[self.edge] = start[self.edge] + (self.table.at(age_ka) - self.table.at(self.start_ka))
        elif self.node_levels is not None:
            h[self.edge] = start[self.edge] + (self.node_levels.at(age_ka)
                                               - self.node_levels.at(self.start_ka))

    def counts(self) -> dict[str, int]:
        """Boundary nodes by what they follow, for the run's summary and sidecar."""
        edge = int(self.edge.sum())
        return {"sea_cells": int(self.sea.sum()), "coast_edge_cells": int(self.coast.sum()),
                **{f"{kind}_edge_cells": edge if kind == self.edge_base else 0
                   for kind in (*EDGE_BASES, "table", COARSE)}}

    def summary(self) -> str:
        """E.g. "16 coast-edge and 0 sea cells follow sea level, 74 edge cells keep their elevation"."""
        counts = self.counts()
        follow = {"fixed": "keep their elevation", "uplift": "rise with the uplift",
                  "table": "follow the --edge-base table",
                  COARSE: "follow the coarse run's surface"}[self.edge_base]
        return (f"{counts['coast_edge_cells']} coast-edge and {counts['sea_cells']} sea cells follow "
                f"sea level, {int(self.edge.sum())} edge cells {follow}")


def coast_cells(terrain: Terrain, coast: str) -> np.ndarray:
    """bool[ny, nx] cells of the coast ``coast``: "none", "all" or a comma list of N, E, S, W
    (domain edges) and nodata (the borders of nodata areas, e.g. a sea clipped as nodata)."""
    parts = [part.strip().lower() for part in coast.split(",")]
    edges = ",".join(part for part in parts if part != "nodata") or "none"
    try:
        return outlet_mask(terrain.grid, edges, nodata_borders="nodata" in parts)
    except ValueError:
        raise InputError(f"--coast must be none, all or a comma list of N, E, S, W and nodata, "
                         f"got '{coast}'.") from None


def edge_base_table(edge_base: str) -> Path | None:
    """The table file that ``--edge-base`` names (None for fixed, uplift and coarse)."""
    return None if edge_base in (*EDGE_BASES, COARSE) else Path(edge_base)


def _read_edge_base(edge_base: str, span_ka: tuple[float, float]) -> Series | None:
    """The ``--edge-base`` table, checked to cover the run's ages ``span_ka`` (ka)."""
    path = edge_base_table(edge_base)
    if path is None:
        return None
    table = read_age_table(path, "edge-base", ("elevation_m",))
    if not table.covers(np.array(span_ka)):
        raise InputError(f"the --edge-base table {path} covers {table.start_ka:g}–{table.end_ka:g} ka, "
                         f"not the whole run from {span_ka[0]:g} to {span_ka[1]:g} ka.")
    return table


def base_levels_from_options(
    terrain: Terrain, outlets: str, dirichlet: Path | None, coast: str, edge_base: str,
    sea_start: float | None, span_ka: tuple[float, float], outlet_cells: np.ndarray | None = None,
) -> BaseLevels:
    """The boundary nodes of a climate run and what each follows, checked before any step.

    Args:
        outlets, dirichlet: draining edges and Dirichlet mask as for :func:`boundaries_from_options`.
        outlet_cells: bool[ny, nx] further outlet cells besides those edges (a nested run's
            boundary cells where its coarse run's water leaves, ``nesting.crossing_outlets``).
        coast: the coast (:func:`coast_cells`); its cells are outlets whatever ``outlets`` says.
        edge_base: "fixed", "uplift" or the path of a table ``age_ka,elevation_m``.
        sea_start: sea level at the start age (m); boundary nodes at or below it are sea.
            None: only the coast is sea.
        span_ka: (start, end) ages of the run (ka).
    """
    coast_mask = coast_cells(terrain, coast)
    fixed = coast_mask if outlet_cells is None else coast_mask | outlet_cells
    nodes = boundaries_from_options(terrain, outlets, None, dirichlet, fixed).outlets(
        terrain.elevation, terrain)
    sea = nodes & ~coast_mask & (False if sea_start is None else terrain.elevation <= sea_start)
    table = _read_edge_base(edge_base, span_ka)
    return BaseLevels(outlets, coast_mask, sea, nodes & ~coast_mask & ~sea,
                      "table" if table is not None else edge_base, table, span_ka[0])
