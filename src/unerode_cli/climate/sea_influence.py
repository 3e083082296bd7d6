"""Whether the choice of sea-level curve can change a climate run: the three ways sea level
enters one (000 §5.1–5.2, DESIGN §7), compared between curves over the run's steps.

1. **The sea itself**: cells at or below the current sea level are outlets, and boundary nodes
   at or below the start's sea level follow it. The sea cannot reach the domain when the
   highest sea level of every curve, at every age the run reads it (the start, each step's
   middle and end), stays below the lowest ground the run can have. That ground is bounded by
   the lowest cell of the input DEM minus |U|·T, the uplift over the run's span T (years) at the
   largest rate |U| (m/y) it uses: backward in time the rock was lower by U·t. The processes are
   taken not to bring ground below the present lowest cell otherwise (rivers do not cut below
   their outlet, and the outlets keep their elevation or follow U).
2. **The downstream K_d**: inside the downstream region K_d follows sea level
   (:class:`~unerode_cli.climate.schedule.DownstreamKd`), so curves that differ at any step
   give different K_d there, whether or not the sea reaches it.
3. **The climate phases**: each step's phase (glacial, end of glacial, interglacial) is
   classified on the sea-level curve (:mod:`unerode_cli.climate.phases`), and the schedule
   sets parameters per phase; curves that classify a step differently give that step other
   parameters.

A curve is inert for a run when none of the three differs between the curves: the sea never
reaches the domain, no cell is in the downstream region (or the curves agree at every step),
and every step has the same phase under every curve.

Units: ages in ka, sea levels and elevations in m relative to present sea level.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CurveForcing:
    """What one sea-level curve gives a run.

    Attributes:
        label: the curve's name in messages (e.g. its file name).
        sea_m: float64[n], the sea level (m) at every age the run reads it (start, middles, ends).
        phases: str[steps], the phase of each step, in step order.
    """

    label: str
    sea_m: np.ndarray
    phases: np.ndarray


@dataclass(frozen=True)
class SeaInfluence:
    """How a choice among sea-level curves acts on one run (see the module docstring).

    Attributes:
        highest_sea_m: the highest sea level (m) of every curve over the run's ages.
        lowest_ground_m: the lowest ground (m) the run can have: the DEM's lowest cell minus
            the uplift over the run (``uplift_m``); −inf where no bound is known.
        uplift_m: |U|·T (m) taken off the lowest cell.
        sea_outlets: whether the run lets the sea drain the domain at all.
        downstream_cells: cells of the downstream region, where K_d follows sea level.
        sea_differs: whether the curves give different sea levels at some age of the run.
        phase_steps_differing: steps whose phase differs between the curves.
        first_phase_difference_ka: the youngest middle age (ka) of such a step, or None.
    """

    highest_sea_m: float
    lowest_ground_m: float
    uplift_m: float
    sea_outlets: bool
    downstream_cells: int
    sea_differs: bool
    phase_steps_differing: int
    first_phase_difference_ka: float | None

    @property
    def reaches(self) -> bool:
        """Whether the sea can reach the domain at some age of the run."""
        return self.sea_outlets and not self.highest_sea_m < self.lowest_ground_m

    @property
    def kd_differs(self) -> bool:
        """Whether the downstream K_d differs between the curves."""
        return self.downstream_cells > 0 and self.sea_differs

    @property
    def inert(self) -> bool:
        """Whether the choice of curve cannot change the run's result."""
        return not (self.reaches or self.kd_differs or self.phase_steps_differing)

    def reasons(self) -> str:
        """Why the curves change nothing, or what they do change, as clauses of a sentence."""
        sea = (f"the sea never reaches the domain (lowest ground {self.lowest_ground_m:.1f} m: the DEM's "
               f"lowest cell less {self.uplift_m:.1f} m of uplift over the run; highest sea level of the "
               f"curves over the run {self.highest_sea_m:.1f} m)" if self.sea_outlets else
               "the sea drains nothing (--no-sea-outlets)")
        if self.reaches:
            sea = (f"the sea reaches the domain (highest sea level {self.highest_sea_m:.1f} m, lowest ground "
                   f"{self.lowest_ground_m:.1f} m)")
        region = ("no cell is in the downstream region" if self.downstream_cells == 0 else
                  f"K_d follows sea level in the {self.downstream_cells} cell(s) of the downstream region"
                  + ("" if self.sea_differs else ", where the curves agree"))
        phases = ("the curves give every step the same climate phase" if not self.phase_steps_differing else
                  f"the curves give {self.phase_steps_differing} step(s) another climate phase, the first "
                  f"at {self.first_phase_difference_ka:g} ka")
        return f"{sea}, {region}, and {phases}"


def sea_influence(curves: Sequence[CurveForcing], mid_ka: np.ndarray, lowest_cell_m: float,
                  uplift_m: float, downstream_cells: int, sea_outlets: bool = True) -> SeaInfluence:
    """Compare the forcing of ``curves`` (at least two) on one run.

    Args:
        curves: each curve's sea levels and phases at the same ages and steps.
        mid_ka: float64[steps], the middle age (ka) of each step.
        lowest_cell_m: the lowest valid cell of the input DEM (m).
        uplift_m: |U|·T, the most the uplift lowers ground over the run (m, ≥ 0; inf when unknown).
        downstream_cells: cells of the downstream region.
        sea_outlets: whether sea-level outlets are on.

    Raises:
        ValueError: fewer than two curves, or curves of different lengths (one sentence).
    """
    if len(curves) < 2:
        raise ValueError("comparing sea-level curves needs at least two")
    first = curves[0]
    if any(c.sea_m.shape != first.sea_m.shape or c.phases.shape != first.phases.shape for c in curves):
        raise ValueError("the sea-level curves compared must cover the same ages and steps")
    differing = np.zeros(first.phases.shape, dtype=bool)
    for curve in curves[1:]:
        differing |= curve.phases != first.phases
    ages = np.asarray(mid_ka, dtype=np.float64)[differing]
    highest = max(float(np.max(c.sea_m)) for c in curves)
    lowest = lowest_cell_m - uplift_m if math.isfinite(uplift_m) else -math.inf
    return SeaInfluence(highest, lowest, uplift_m, sea_outlets, int(downstream_cells),
                        any(not np.array_equal(c.sea_m, first.sea_m) for c in curves[1:]),
                        int(differing.sum()), float(np.min(ages)) if ages.size else None)
