"""River incision rates per period (000 §6.3.2, Fig. 13).

Incision is the lowering of the riverbed relative to the rock it cuts; with the heights H of
past beds above today's (``history``), the mean incision rate between an older age a₁ and a
younger age a₂ is

    I = (H(a₁) − H(a₂)) / (a₁ − a₂)          (m/ka = 1000 mm/ka)

averaged along the river, as 000 does "across multiple locations along the river".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.analysis.history import RiverHistory

MM_PER_M = 1000.0


def incision_rate(height_old_m: float, height_young_m: float, old_ka: float, young_ka: float) -> float:
    """Mean incision rate (mm/ka) between two ages (ka) from the bed heights at them (m)."""
    if old_ka == young_ka:
        raise ValueError("an incision period needs two different ages")
    return (height_old_m - height_young_m) / (old_ka - young_ka) * MM_PER_M


@dataclass(frozen=True)
class IncisionPeriod:
    """An observed incision rate (``old_ka`` > ``young_ka``).

    Attributes:
        line: line number in the file (1 = header), for messages.
        old_ka, young_ka: the period's bounds (ka).
        rate_mm_per_ka: observed mean incision rate (mm/ka).
        uncertainty_mm_per_ka: ± uncertainty, None when unknown.
        name: label ("" when none).
    """

    line: int
    old_ka: float
    young_ka: float
    rate_mm_per_ka: float
    uncertainty_mm_per_ka: float | None = None
    name: str = ""


@dataclass(frozen=True)
class IncisionResult:
    period: IncisionPeriod
    simulated_mm_per_ka: float

    @property
    def residual_mm_per_ka(self) -> float:
        """Simulated − observed rate (mm/ka)."""
        return self.simulated_mm_per_ka - self.period.rate_mm_per_ka


def compare_incision(history: RiverHistory, periods: list[IncisionPeriod]) -> list[IncisionResult]:
    """Simulated mean incision rate over each observed period.

    Raises:
        ValueError: naming the file line of a period not covered by the snapshots.
    """
    results = []
    for period in periods:
        for age in (period.old_ka, period.young_ka):
            if not history.covers(age):
                raise ValueError(
                    f"line {period.line}: age {age:g} ka is not covered by the snapshots "
                    f"(0 to {history.oldest_ka:g} ka)"
                )
        rate = incision_rate(history.height(period.old_ka), history.height(period.young_ka),
                             period.old_ka, period.young_ka)
        results.append(IncisionResult(period, rate))
    return results


def snapshot_rates(history: RiverHistory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean incision rate between consecutive snapshots: (old ages, young ages, mm/ka)."""
    means = np.nanmean(history.heights, axis=1)
    old, young = history.ages_ka[1:], history.ages_ka[:-1]
    return old, young, (means[1:] - means[:-1]) / (old - young) * MM_PER_M
