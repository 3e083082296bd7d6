"""Stop a run whose elevations blow up, before anything of it is written.

An explicit scheme run past its stable step, or a solver that fails, does not crash: it writes
a DEM at −10²³ m and reports it as a result. Every time-stepping job checks its elevation after
each step: all cells of the domain finite, and no cell moved from where it started by more
than ``RELIEF_FACTOR`` × the DEM's relief + ``FLOOR_M`` + max|U|·|t| (uplift U in m/y, t the
simulated years so far). Real runs stay far inside this bound (erosion and unerosion rework
the relief they are given; they do not multiply it), so passing it means the run diverged.
A DEM whose relief itself overflows float64 (elevations of ±1e308 m) is refused when the guard
is made, before the first step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from unerode_cli.errors import InputError, RunFailure

#: A cell may move by this many times the DEM's relief (m/m) ...
RELIEF_FACTOR = 5.0
#: ... plus this much (m), so that nearly flat DEMs have room to evolve.
FLOOR_M = 100.0


@dataclass
class DivergenceGuard:
    """Checks elevations against their start (``reference``, m, NaN outside the domain).

    ``uplift_rate``: the largest |U| of the run (m/y), whose displacement is allowed on top.
    ``hint``: what the user can do, appended to the message (e.g. "lower --dt").
    """

    reference: np.ndarray
    uplift_rate: float = 0.0
    hint: str = "lower --dt"
    inside: np.ndarray = field(init=False, repr=False)
    relief: float = field(init=False)

    def __post_init__(self) -> None:
        self.reference = np.ascontiguousarray(self.reference, dtype=np.float64)
        self.inside = np.isfinite(self.reference)
        values = self.reference[self.inside]
        with np.errstate(over="ignore", invalid="ignore"):
            self.relief = float(values.max() - values.min()) if values.size else 0.0
        if not np.isfinite(self.relief):
            raise InputError(
                f"the DEM's elevations span {values.min():.3g} to {values.max():.3g} m, a relief too large "
                "to compute with; check its values and units (metres).")

    def share(self, reference: np.ndarray, inside: np.ndarray) -> None:
        """Measure against ``reference`` and ``inside`` from now on, arrays the caller keeps anyway:
        the same start values (e.g. a float32 copy that holds them exactly) and the same domain
        mask, so the guard holds no grid of its own."""
        self.reference, self.inside = reference, inside

    def allowed_change(self, elapsed_years: float) -> float:
        """Largest |h − h₀| (m) a sane run may reach after ``elapsed_years``."""
        return RELIEF_FACTOR * self.relief + FLOOR_M + self.uplift_rate * abs(elapsed_years)

    def check(self, elevation: np.ndarray, elapsed_years: float, where: str) -> None:
        """Raise :class:`RunFailure` when ``elevation`` (m) has diverged; ``where`` says when
        (e.g. "in step 12 (t = 3000 y)")."""
        finite, change = _largest_change(np.ascontiguousarray(elevation, dtype=np.float64).ravel(),
                                         self.reference.ravel(), self.inside.ravel())
        if not finite:
            raise RunFailure(f"the run diverged {where}: elevations became NaN or infinite; {self.hint}.")
        if change > self.allowed_change(elapsed_years):
            raise RunFailure(
                f"the run diverged {where}: a cell moved by {change:.3g} m, more than {RELIEF_FACTOR:g} × "
                f"the DEM's relief of {self.relief:.4g} m (+ {FLOOR_M:g} m and the uplift) allows; "
                f"{self.hint}.")


@numba.njit(cache=True)
def _largest_change(elevation, reference, inside):
    """(every inside cell finite, max |elevation − reference| over inside cells (m)) in one pass."""
    largest = 0.0
    for i in range(elevation.size):
        if inside[i]:
            value = elevation[i]
            if not np.isfinite(value):
                return False, np.inf
            largest = max(largest, abs(value - reference[i]))
    return True, largest


def max_rate(rate: float | np.ndarray) -> float:
    """max |rate| of a number or a raster (NaN cells ignored)."""
    values = np.abs(np.asarray(rate, dtype=np.float64))
    return float(np.nanmax(values)) if values.size else 0.0
