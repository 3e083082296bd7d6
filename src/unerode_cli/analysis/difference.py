"""Difference of two DEMs on the same grid and its statistics."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DifferenceStats:
    """Statistics of d = B − A over the cells valid in both (m).

    Attributes:
        cells: number of cells compared.
        rmse_m: √mean(d²). mean_m: mean(d) (bias). mae_m: mean|d|.
        min_m, max_m: extreme differences.
        correlation: Pearson correlation of A and B (NaN when either is constant).
    """

    cells: int
    rmse_m: float
    mean_m: float
    mae_m: float
    min_m: float
    max_m: float
    correlation: float


def difference(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, DifferenceStats]:
    """B − A (m, NaN where either is nodata) and its statistics.

    Raises:
        ValueError: different shapes, or no cell valid in both.
    """
    if a.shape != b.shape:
        raise ValueError(f"the two DEMs have different shapes, {a.shape} and {b.shape}")
    both = np.isfinite(a) & np.isfinite(b)
    if not both.any():
        raise ValueError("the two DEMs have no valid cell in common")
    d = np.where(both, b - a, np.nan)
    values = d[both]
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = float(np.corrcoef(a[both], b[both])[0, 1]) if values.size > 1 else float("nan")
    return d, DifferenceStats(
        cells=int(values.size),
        rmse_m=float(np.sqrt(np.mean(values**2))),
        mean_m=float(values.mean()),
        mae_m=float(np.abs(values).mean()),
        min_m=float(values.min()),
        max_m=float(values.max()),
        correlation=correlation,
    )
