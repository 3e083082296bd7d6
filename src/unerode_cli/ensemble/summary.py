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


#: The statistics of one number per member (e.g. the simulated height of the past riverbed at a
#: terrace): the median, the 5 and 95 percentiles (NumPy's linear interpolation), the extremes
#: and the standard deviation (population, ddof = 0), in the unit of the numbers.
SPREAD = ("p50", "p5", "p95", "min", "max", "std")


def value_spread(values: Sequence[float | None]) -> dict[str, float] | None:
    """:data:`SPREAD` of the finite ``values`` (one per member; None or NaN for a member
    without one), with ``members`` their count; None when no member has a value."""
    known = np.array([v for v in values if v is not None and math.isfinite(v)], dtype=np.float64)
    if known.size == 0:
        return None
    p50, p5, p95 = np.percentile(known, [50.0, 5.0, 95.0])
    return {"p50": float(p50), "p5": float(p5), "p95": float(p95), "min": float(known.min()),
            "max": float(known.max()), "std": float(known.std()), "members": int(known.size)}


def median_position(count: int) -> int:
    """Position (0-based) in a ranking of ``count`` ≥ 1 members of the median member: the middle
    one, the better of the two middle ones for an even count."""
    if count < 1:
        raise ValueError("a ranking of no member has no median member")
    return (count - 1) // 2
