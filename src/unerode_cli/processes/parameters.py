"""Declarations of process parameters: one place feeds CLI help, validation and provenance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ParamSpec:
    """One process parameter.

    Attributes:
        name: identifier (also the CLI option, with ``_`` → ``-``).
        unit: SI unit written in help texts, e.g. ``"m/y"``.
        default: default value.
        help: one-line description.
        minimum / maximum: valid closed range (None = unbounded).
        raster: whether a raster on the grid may replace the scalar.
        symbol: the paper's symbol when it differs from ``name`` (e.g. ``"K_d"``); it is
            offered as a second CLI option name.
    """

    name: str
    unit: str
    default: float
    help: str
    minimum: float | None = None
    maximum: float | None = None
    raster: bool = False
    symbol: str = ""

    def check(self, value: float | np.ndarray) -> None:
        """Raise ValueError with one sentence when ``value`` is outside the valid range."""
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"parameter {self.name} must be finite")
        if arr.ndim > 0 and not self.raster:
            raise ValueError(f"parameter {self.name} must be a scalar, not a raster")
        if self.minimum is not None and np.any(arr < self.minimum):
            raise ValueError(
                f"parameter {self.name} must be ≥ {self.minimum} {self.unit}, got {np.min(arr):g}"
            )
        if self.maximum is not None and np.any(arr > self.maximum):
            raise ValueError(
                f"parameter {self.name} must be ≤ {self.maximum} {self.unit}, got {np.max(arr):g}"
            )
