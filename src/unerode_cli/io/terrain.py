"""The ``Terrain`` data model (DESIGN §4): elevations in metres plus georeferencing."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np
from affine import Affine

from unerode_cli.errors import InputError
from unerode_cli.grid import Grid


@dataclass
class Terrain:
    """A heightfield and its georeferencing.

    Attributes:
        elevation: float64[ny, nx] in metres, row 0 = north. Nodata cells hold NaN.
        dx, dy: east-west and north-south cell size (m).
        crs_wkt: coordinate reference system as WKT ("" when the source had none).
        transform: affine pixel → CRS transform (north-up, not rotated).
        nodata: the nodata value written to files (None: no nodata value declared).
        tags: free-form metadata (band unit, AREA_OR_POINT, history, ...).
    """

    elevation: np.ndarray
    dx: float
    dy: float
    crs_wkt: str = ""
    transform: Affine = field(default_factory=Affine.identity)
    nodata: float | None = None
    tags: dict[str, str] = field(default_factory=dict)

    @property
    def nodata_mask(self) -> np.ndarray:
        """bool[ny, nx], True outside the domain."""
        return ~np.isfinite(self.elevation)

    @property
    def shape(self) -> tuple[int, int]:
        return self.elevation.shape  # type: ignore[return-value]

    @cached_property
    def grid(self) -> Grid:
        """The computational grid (cell sizes and domain mask), built once: a Terrain's
        elevation is never changed in place (``with_elevation`` makes a new Terrain)."""
        return Grid(self.dx, self.dy, np.isfinite(self.elevation))

    def check_valid(self, source: Path | str) -> None:
        """Refuse (InputError) a heightfield without a single valid cell, before any work;
        ``source`` names it in the message."""
        if self.nodata_mask.all():
            raise InputError(f"{source} has no valid cell (every cell is nodata or NaN).")

    def holding(self, values: np.ndarray) -> Terrain:
        """A Terrain on the same georeferencing whose elevation is ``values`` itself, not a
        copy (float64[ny, nx] of this shape, NaN on nodata as the caller sets it): for a
        one-shot job that writes a field it made and will not change."""
        if values.shape != self.shape or values.dtype != np.float64:
            raise ValueError(f"values of shape {values.shape} ({values.dtype}) cannot stand for a "
                             f"float64 heightfield of shape {self.shape}")
        return replace(self, elevation=values, tags=dict(self.tags))

    def with_elevation(self, elevation: np.ndarray) -> Terrain:
        """A copy with new elevations (same georeferencing); nodata cells stay nodata."""
        new = np.array(elevation, dtype=np.float64, copy=True)
        new[self.nodata_mask] = np.nan
        return replace(self, elevation=new, tags=dict(self.tags))
