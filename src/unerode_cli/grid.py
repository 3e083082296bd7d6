"""The computational grid of a heightfield: cell sizes in metres and the domain mask.

Row 0 is north; ``dx`` is the east-west cell size and ``dy`` the north-south one, both in
metres (they differ on geographic rasters). Cells outside ``valid`` are nodata: they are never
eroded, never receive flow and are written back as nodata.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Grid:
    """Cell geometry and domain of a heightfield.

    Attributes:
        dx: east-west cell size (m).
        dy: north-south cell size (m).
        valid: bool[ny, nx], True for cells inside the domain (not nodata).
    """

    dx: float
    dy: float
    valid: np.ndarray

    def __post_init__(self) -> None:
        if not (self.dx > 0 and self.dy > 0):
            raise ValueError(f"cell sizes must be positive, got dx={self.dx} m, dy={self.dy} m")
        if self.valid.ndim != 2 or self.valid.dtype != np.bool_:
            raise ValueError("valid must be a 2-D boolean array")

    @classmethod
    def full(cls, shape: tuple[int, int], dx: float, dy: float | None = None) -> Grid:
        """A grid whose every cell is inside the domain."""
        return cls(float(dx), float(dx if dy is None else dy), np.ones(shape, dtype=bool))

    @property
    def shape(self) -> tuple[int, int]:
        return self.valid.shape  # type: ignore[return-value]

    @property
    def cell_area(self) -> float:
        """Area of one cell (m²)."""
        return self.dx * self.dy
