"""Boundary conditions of a run: outlets and Dirichlet (fixed-elevation) nodes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.hydro.outlets import outlet_mask
from unerode_cli.io.grid_rasters import load_on_grid
from unerode_cli.io.terrain import Terrain


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
    terrain: Terrain, edges: str, sea_level: float | None, dirichlet: Path | None
) -> Boundaries:
    """Build and check the boundaries given on the command line (exit 2 when there is no outlet)."""
    mask = None
    if dirichlet is not None:
        layer = load_on_grid(dirichlet, terrain, "Dirichlet mask")
        mask = np.isfinite(layer) & (layer != 0)
    if sea_level is not None and not np.isfinite(sea_level):
        raise InputError("--sea-level must be a finite elevation in metres.")
    bounds = Boundaries(edges, sea_level, mask)
    if not bounds.outlets(terrain.elevation, terrain).any():
        raise InputError(
            "the DEM has no outlet at all: choose draining edges with --outlets, a --sea-level, "
            "a --dirichlet mask, or use a DEM with nodata borders."
        )
    return bounds
