"""The mass budget every process step returns: volumes removed, added and carried out (m³)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MassBudget:
    """Volumes moved by one step of a process (m³), uplift excluded.

    ``eroded`` is the volume taken from the surface (Σ max(0, −e)·A over free cells, with e the
    elevation change due to the process alone), ``deposited`` the volume added to it
    (Σ max(0, e)·A), and ``outflux`` the volume that leaves the domain through outlets or edges
    (negative when a backward step brings material in), and ``inflow`` the volume that enters
    it from upstream of the map (fluvial inflow; negative when a backward step sends it back).
    A mass-conserving process has eroded + inflow − deposited − outflux = 0.
    """

    eroded: float
    deposited: float
    outflux: float
    inflow: float = 0.0

    @property
    def residual(self) -> float:
        """eroded + inflow − deposited − outflux (m³); zero up to rounding for a conserving
        process."""
        return self.eroded + self.inflow - self.deposited - self.outflux


@dataclass(frozen=True)
class SurfaceChange:
    """What one step of a process does to the surface.

    Attributes:
        dh: float64[ny, nx] elevation change (m), uplift included where the process applies it;
            0 on fixed cells and nodata.
        budget: the volumes the step moved.
    """

    dh: np.ndarray
    budget: MassBudget
