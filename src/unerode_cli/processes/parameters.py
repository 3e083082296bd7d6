"""Declarations of process parameters: one place feeds CLI help, validation and provenance."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from unerode_cli.grid import Grid


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
        if isinstance(value, float) and self._plainly_valid(value):
            return  # the usual case, checked in every time step: no array round trip
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"parameter {self.name} must be finite")
        if arr.ndim > 0 and not self.raster:
            raise ValueError(f"parameter {self.name} must be a scalar, not a raster")
        unit = "" if self.unit in ("", "1") else f" {self.unit}"  # "1": dimensionless
        if self.minimum is not None and np.any(arr < self.minimum):
            raise ValueError(
                f"parameter {self.name} must be ≥ {self.minimum:g}{unit}, got {np.min(arr):g}"
            )
        if self.maximum is not None and np.any(arr > self.maximum):
            raise ValueError(
                f"parameter {self.name} must be ≤ {self.maximum:g}{unit}, got {np.max(arr):g}"
            )

    def _plainly_valid(self, value: float) -> bool:
        """Whether the number ``value`` is finite and in range (``check`` says why when not)."""
        return (math.isfinite(value) and (self.minimum is None or value >= self.minimum)
                and (self.maximum is None or value <= self.maximum))


def check_fields(params: Any, specs: Sequence[ParamSpec], grid: Grid) -> None:
    """Check every field of the parameter dataclass ``params`` against its spec: rasters must
    have the grid's shape, and values inside the domain must be in range (raster values on
    nodata cells are not read). Raises ValueError with one sentence."""
    by_name = {spec.name: spec for spec in specs}
    for field in fields(params):
        check_on_grid(by_name[field.name], getattr(params, field.name), grid.shape, grid.valid)


def check_on_grid(spec: ParamSpec, value: float | np.ndarray, shape: tuple[int, int],
                  valid: np.ndarray | None = None) -> None:
    """Check one parameter value against ``spec``: a raster must have the grid's ``shape``, and
    its values (only those where ``valid``, when given) must be in range. Raises ValueError
    with one sentence."""
    if np.ndim(value):
        if np.shape(value) != tuple(shape):
            raise ValueError(
                f"parameter {spec.name} has shape {np.shape(value)}, the grid has {tuple(shape)}"
            )
        if valid is not None:
            value = np.asarray(value)[valid]
    spec.check(value)


#: The uplift rate, shared by every process that takes it: a combined run applies it once.
UPLIFT = ParamSpec(
    "uplift",
    "m/y",
    0.0,
    "uplift rate U (000 Eq. 3); negative for subsidence",
    raster=True,
    symbol="U",
)
