"""Uplift through time: a table of the uplift rate by age, alone or as a factor of a map.

000 Eq. 3 has an uplift term U (m/y) that "can vary in space and time" (000 §6): the Têt case
uplifts by 250 mm/ka over 5 Ma, and 000 §6.3.2 suggests its river area subsided between 2 and
1 Ma. A run takes U from a table of ages (ka) and either

- U itself (m/y; negative = subsidence), the same everywhere, or
- a dimensionless factor f(age) multiplying a map U₀(x) (m/y): U(x, age) = f(age) · U₀(x),

linear in age between the table's rows. A step uses the table's mean over its span, so that
the elevation it adds, U·dt, is exactly ∫U dt of the table (the value at the step's middle age
when no row falls inside the step).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unerode_cli.climate.chronology import Series

#: Value column of a table of U (m/y) and of a table of factors of a map.
RATE_COLUMN = "U_m_per_y"
FACTOR_COLUMN = "factor"


@dataclass(frozen=True)
class UpliftHistory:
    """U(x, age) = table(age) · pattern(x) (module docstring).

    Attributes:
        table: U in m/y by age (ka), or a dimensionless factor when ``pattern`` is a map.
        pattern: the map of U (m/y) that a factor table multiplies; 1.0 for a table of U.
    """

    table: Series
    pattern: float | np.ndarray = 1.0

    def over(self, start_ka: float, end_ka: float) -> float | np.ndarray:
        """U (m/y) of a step from ``start_ka`` to ``end_ka`` (ka): the table's mean over the
        step times the pattern, so that U·dt = ∫U dt."""
        return self.table.mean(start_ka, end_ka) * self.pattern
