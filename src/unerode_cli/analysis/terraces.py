"""Dated terraces against simulated riverbeds (000 §6.3, Fig. 12).

An observation says that at ``age_ka`` the riverbed was ``height_m`` above today's river,
at one place (a chainage along the river) or for the river as a whole. The simulated value is
the height H of the simulated past bed above the present one (``history.RiverHistory``);
the residual is simulated − observed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.analysis.history import RiverHistory


@dataclass(frozen=True)
class Terrace:
    """One dated level.

    Attributes:
        line: line number in the observations file (1 = header), for messages.
        age_ka: age of the level (ka).
        height_m: observed height above the present river (m).
        uncertainty_m: ± uncertainty of the height (m), None when unknown.
        name: label ("" when none).
        chainage_m: where along the river (m from its downstream end); None = the mean of the
            whole river.
        distance_m: distance from the observation's x, y to the river (m), None if not given.
    """

    line: int
    age_ka: float
    height_m: float
    uncertainty_m: float | None = None
    name: str = ""
    chainage_m: float | None = None
    distance_m: float | None = None


@dataclass(frozen=True)
class TerraceResult:
    """An observation and its simulated counterpart (m)."""

    terrace: Terrace
    simulated_m: float

    @property
    def residual_m(self) -> float:
        """Simulated − observed height (m)."""
        return self.simulated_m - self.terrace.height_m

    @property
    def within_uncertainty(self) -> bool | None:
        """|residual| ≤ uncertainty; None when the observation has no uncertainty."""
        if self.terrace.uncertainty_m is None:
            return None
        return bool(abs(self.residual_m) <= self.terrace.uncertainty_m)


@dataclass(frozen=True)
class Fit:
    """Overall agreement: root-mean-square and mean of the residuals (m)."""

    rmse_m: float
    bias_m: float
    count: int
    within: int
    with_uncertainty: int


def compare_terraces(history: RiverHistory, terraces: list[Terrace]) -> list[TerraceResult]:
    """Simulated height of every terrace.

    Raises:
        ValueError: naming the file line of a terrace whose age is not covered by the
            snapshots or whose chainage is off the river.
    """
    results = []
    for terrace in terraces:
        if not history.covers(terrace.age_ka):
            raise ValueError(
                f"line {terrace.line}: age {terrace.age_ka:g} ka is not covered by the snapshots "
                f"(0 to {history.oldest_ka:g} ka)"
            )
        try:
            simulated = history.height(terrace.age_ka, terrace.chainage_m)
        except ValueError as exc:
            raise ValueError(f"line {terrace.line}: {exc}") from None
        if not np.isfinite(simulated):
            raise ValueError(f"line {terrace.line}: the simulated riverbed is nodata there")
        results.append(TerraceResult(terrace, simulated))
    return results


def fit(results: list[TerraceResult]) -> Fit:
    """RMSE and bias of the residuals; NaN for both when there is no observation."""
    residuals = np.array([result.residual_m for result in results])
    flags = [result.within_uncertainty for result in results]
    if residuals.size == 0:
        return Fit(float("nan"), float("nan"), 0, 0, 0)
    return Fit(
        rmse_m=float(np.sqrt(np.mean(residuals**2))),
        bias_m=float(np.mean(residuals)),
        count=int(residuals.size),
        within=sum(flag is True for flag in flags),
        with_uncertainty=sum(flag is not None for flag in flags),
    )
