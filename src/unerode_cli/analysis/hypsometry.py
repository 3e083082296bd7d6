"""Hypsometry: the distribution of elevations of a terrain (001 §7, Fig. 15).

001 compares terrains by their elevation histograms "uniformly scaled to match the highest
elevations", i.e. elevations divided by the terrain's highest one (``normalise="max"``). The
classic relative height (h − h_min)/(h_max − h_min) of Strahler (1952) is ``"range"``, and
``"none"`` keeps metres. Each bin holds the fraction of the domain's area in it (they sum to
1; all cells have the same area). The hypsometric integral is
HI = (mean − min)/(max − min) (Pike & Wilson 1971); the hypsometric maximum is the centre of
the fullest bin, which 001 finds just above the ELA on glacial terrains.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

NORMALISATIONS = ("max", "range", "none")


@dataclass(frozen=True)
class Hypsometry:
    """Elevation histogram of one terrain.

    Attributes:
        edges: float64[bins + 1] bin edges, in the normalised unit.
        fraction: float64[bins] fraction of the area in each bin.
        normalise: "max", "range" or "none".
        minimum_m, maximum_m, mean_m: elevation statistics (m).
        mode_m: centre of the fullest bin (m), the hypsometric maximum.
        integral: hypsometric integral HI (dimensionless, 0..1).
    """

    edges: np.ndarray
    fraction: np.ndarray
    normalise: str
    minimum_m: float
    maximum_m: float
    mean_m: float
    mode_m: float
    integral: float

    @property
    def centres(self) -> np.ndarray:
        return 0.5 * (self.edges[1:] + self.edges[:-1])

    @property
    def area_above(self) -> np.ndarray:
        """float64[bins] fraction of the area above each bin's lower edge (Strahler's curve)."""
        return np.cumsum(self.fraction[::-1])[::-1]


def _scaling(low: float, high: float, normalise: str) -> tuple[float, float]:
    """(offset, scale) with normalised = (h − offset)/scale."""
    if normalise == "max":
        if high <= 0.0:
            raise ValueError(f"normalising by the highest elevation needs it above 0 m, got {high:g} m")
        return 0.0, high
    if normalise == "range":
        return low, (high - low) or 1.0
    return 0.0, 1.0


def hypsometry(elevation: np.ndarray, bins: int = 50, normalise: str = "max") -> Hypsometry:
    """Hypsometry of the finite cells of ``elevation`` (m).

    Raises:
        ValueError: no finite cell, fewer than one bin, or an unknown normalisation.
    """
    if normalise not in NORMALISATIONS:
        raise ValueError(f"normalisation must be one of {', '.join(NORMALISATIONS)}, got {normalise!r}")
    if bins < 1:
        raise ValueError(f"the histogram needs at least one bin, got {bins}")
    heights = elevation[np.isfinite(elevation)]
    if heights.size == 0:
        raise ValueError("the terrain has no valid cell")
    low, high = float(heights.min()), float(heights.max())
    offset, scale = _scaling(low, high, normalise)
    span = (low, high) if high > low else (low - 0.5, high + 0.5)
    counts, edges_m = np.histogram(heights, bins=bins, range=span)
    fraction = counts / heights.size
    fullest = int(np.argmax(counts))
    mean = float(heights.mean())
    return Hypsometry(
        edges=(edges_m - offset) / scale,
        fraction=fraction,
        normalise=normalise,
        minimum_m=low,
        maximum_m=high,
        mean_m=mean,
        mode_m=float(0.5 * (edges_m[fullest] + edges_m[fullest + 1])),
        integral=(mean - low) / (high - low) if high > low else float("nan"),
    )
