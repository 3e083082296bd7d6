"""What an ensemble's members say together: cell-wise statistics of their rasters and the
ranking of their scores."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

#: The statistics of a stack of member rasters, by name: the mean, the standard deviation
#: (population, ddof = 0) and the 5, 50 and 95 percentiles (linear interpolation between the
#: sorted members, NumPy's default).
STATISTICS = ("mean", "std", "p5", "p50", "p95")
PERCENTILES = {"p5": 5.0, "p50": 50.0, "p95": 95.0}


def cell_statistics(stack: np.ndarray) -> dict[str, np.ndarray]:
    """float64[ny, nx] rasters of :data:`STATISTICS` over the first axis of ``stack``
    (members × ny × nx, metres). A cell that is NaN (nodata) in any member is NaN in every
    statistic: the members disagree on the domain there."""
    if stack.ndim != 3 or stack.shape[0] == 0:
        raise ValueError(f"expected a stack of at least one raster, got the shape {stack.shape}")
    values = np.asarray(stack, dtype=np.float64)
    outside = np.isnan(values).any(axis=0)
    stats = {"mean": values.mean(axis=0), "std": values.std(axis=0)}
    quantiles = np.percentile(values, list(PERCENTILES.values()), axis=0)
    stats.update(zip(PERCENTILES, quantiles, strict=True))
    for raster in stats.values():
        raster[outside] = np.nan
    return stats


def ranks(scores: Sequence[float | None]) -> list[int | None]:
    """Rank (1 = best, the lowest score) of each score; None for a missing or non-finite score.
    Ties keep the members' order."""
    known = [(score, i) for i, score in enumerate(scores) if score is not None and math.isfinite(score)]
    result: list[int | None] = [None] * len(scores)
    for rank, (_, i) in enumerate(sorted(known), start=1):
        result[i] = rank
    return result
