"""Rivers entering the map through time (000 §6.3.1): the water and sediment that a fluvial
step receives from upstream of the map, at a few ages (keyframes), linear in age between them.

A constant inflow (``--inflow`` without ages) is a history of one keyframe. The keyframes come
from an inflow table with an ``age_ka`` column or from the snapshots of a coarser run over a
larger area (``run.nesting``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.processes.fluvial import Inflow


@dataclass(frozen=True)
class InflowHistory:
    """Inflow at the cells where rivers enter, at keyframe ages.

    Attributes:
        shape: (ny, nx) of the grid the cells are on.
        cells: int64[M] flat indices of the cells where rivers enter.
        ages_ka: float64[K] keyframe ages (ka), increasing; one keyframe: constant in time.
        discharge: float64[K, M] water discharge Q_in (m³/y) entering each cell at each age.
        sediment: float64[K, M] sediment flux Q_s,in (m³/y) entering each cell at each age.
    """

    shape: tuple[int, int]
    cells: np.ndarray
    ages_ka: np.ndarray
    discharge: np.ndarray
    sediment: np.ndarray

    @property
    def constant(self) -> bool:
        return self.ages_ka.size == 1

    @property
    def span_ka(self) -> tuple[float, float]:
        """(first, last) keyframe ages (ka)."""
        return float(self.ages_ka[0]), float(self.ages_ka[-1])

    def covers(self, age_ka: float) -> bool:
        """Whether ``age_ka`` lies within the keyframes (always, for a constant inflow)."""
        lo, hi = self.span_ka
        return self.constant or lo - 1e-9 <= age_ka <= hi + 1e-9

    def at(self, age_ka: float | None = None) -> Inflow:
        """The inflow grids (m³/y per cell) at ``age_ka``, linear between keyframes (the only
        keyframe for a constant inflow, where ``age_ka`` may be None)."""
        if self.constant:
            q, qs = self.discharge[0], self.sediment[0]
        else:
            if age_ka is None or not self.covers(age_ka):
                raise ValueError(f"the inflow is known from {self.span_ka[0]:g} to "
                                 f"{self.span_ka[1]:g} ka, not at {age_ka} ka")
            q, qs = interpolate_rows(self.ages_ka, self.discharge, age_ka), \
                interpolate_rows(self.ages_ka, self.sediment, age_ka)
        discharge = np.zeros(self.shape, dtype=np.float64)
        sediment = np.zeros(self.shape, dtype=np.float64)
        np.add.at(discharge.ravel(), self.cells, q)
        np.add.at(sediment.ravel(), self.cells, qs)
        return Inflow(discharge, sediment)


def interpolate_rows(ages: np.ndarray, values: np.ndarray, age: float) -> np.ndarray:
    """Rows of ``values`` (float[K, M]) linear in ``ages`` (float[K], increasing) at ``age``."""
    k = int(np.clip(np.searchsorted(ages, age), 1, ages.size - 1))
    a0, a1 = ages[k - 1], ages[k]
    w = float(np.clip((age - a0) / (a1 - a0), 0.0, 1.0))
    return (1.0 - w) * values[k - 1] + w * values[k]
