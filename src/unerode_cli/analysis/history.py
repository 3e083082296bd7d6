"""Heights of past riverbeds above the present one, along a river and through time.

A terrace deposited at age a by a river whose bed was at z_a(c) (chainage c, m) is found
today at z_a(c) + U·a above sea level when the land rose at the uplift rate U (m/y); its
height above the present riverbed z_0(c) is

    H_a(c) = z_a(c) + U·a − z_0(c)                                     (m)

which is what dated terraces measure (000 §6.3, Fig. 12). Between snapshot ages, H is
interpolated linearly in age; the present (age 0, H = 0) is always known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

YEARS_PER_KA = 1000.0


@dataclass(frozen=True)
class RiverHistory:
    """H_a(c) on the snapshot ages.

    Attributes:
        chainage: float64[k] distance along the river from its downstream end (m).
        ages_ka: float64[t] snapshot ages (ka), increasing, the first one 0 (the present).
        heights: float64[t, k] height of the riverbed at each age above the present one (m).
    """

    chainage: np.ndarray
    ages_ka: np.ndarray
    heights: np.ndarray

    @property
    def oldest_ka(self) -> float:
        return float(self.ages_ka[-1])

    def covers(self, age_ka: float) -> bool:
        """Whether ``age_ka`` lies between the present and the oldest snapshot."""
        return 0.0 <= age_ka <= self.oldest_ka

    def profile(self, age_ka: float) -> np.ndarray:
        """H at ``age_ka`` (m) along the river, linear in age between snapshots."""
        if not self.covers(age_ka):
            raise ValueError(f"age {age_ka:g} ka is outside the snapshots (0 to {self.oldest_ka:g} ka)")
        upper = int(np.searchsorted(self.ages_ka, age_ka, side="left"))
        if self.ages_ka[upper] == age_ka:
            return self.heights[upper]
        lower = upper - 1
        weight = (age_ka - self.ages_ka[lower]) / (self.ages_ka[upper] - self.ages_ka[lower])
        return (1.0 - weight) * self.heights[lower] + weight * self.heights[upper]

    def height(self, age_ka: float, chainage: float | None = None) -> float:
        """H (m) at ``age_ka`` and ``chainage`` (m), or its mean along the river when
        ``chainage`` is None."""
        profile = self.profile(age_ka)
        if chainage is None:
            return float(np.nanmean(profile))
        if not 0.0 <= chainage <= self.chainage[-1]:
            raise ValueError(f"chainage {chainage:g} m is outside the river (0 to {self.chainage[-1]:g} m)")
        finite = np.isfinite(profile)
        return float(np.interp(chainage, self.chainage[finite], profile[finite]))


def river_history(
    chainage: np.ndarray,
    present_bed: np.ndarray,
    snapshots: list[tuple[float, np.ndarray]],
    uplift: float = 0.0,
) -> RiverHistory:
    """Build H_a(c) from the present bed profile and ``(age_ka, bed profile)`` snapshots (m).

    Args:
        chainage: float64[k] (m).
        present_bed: float64[k] present riverbed elevation z_0 (m).
        snapshots: past bed profiles z_a (m) on the same samples; a snapshot at age 0 is
            ignored (the present is the reference).
        uplift: uniform rock uplift rate U (m/y) since each age (0: heights as simulated).

    Raises:
        ValueError: a negative age, or two snapshots with the same age.
    """
    ages = [age for age, _ in snapshots]
    if any(age < 0 for age in ages):
        raise ValueError(f"snapshot ages must be ≥ 0 ka, got {min(ages):g}")
    past = sorted(((age, bed) for age, bed in snapshots if age > 0), key=lambda item: item[0])
    for (first, _), (second, _) in zip(past, past[1:], strict=False):
        if first == second:
            raise ValueError(f"two snapshots have the same age, {first:g} ka")
    ages_ka = np.array([0.0] + [age for age, _ in past])
    heights = np.zeros((ages_ka.size, present_bed.size))
    for i, (age, bed) in enumerate(past, start=1):
        heights[i] = bed + uplift * age * YEARS_PER_KA - present_bed
    return RiverHistory(np.asarray(chainage, dtype=np.float64), ages_ka, heights)
