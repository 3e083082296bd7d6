"""Sea level through time: from a sea-level table, or from benthic δ18O scaled linearly.

000 §5.1–5.2: sea level falls by up to ~150 m in glacial periods; the downstream deposition
coefficient K_d and the Dirichlet boundary nodes follow it. A sea-level reconstruction (e.g.
Spratt & Lisiecki 2016) is used directly when given; when only a δ18O stack (LR04) is given,
sea level is taken as a linear function of δ18O (DESIGN §7):

    sea(m) = intercept + slope · δ18O(‰)

That is a first-order approximation: benthic δ18O mixes ice volume (sea level) with deep-water
temperature, so the linear map reproduces the large glacial–interglacial swings (tens of
metres of error at some ages), not the details.

Units: ages in ka (thousands of years before present) — these table functions work in ka by
nature; sea level in metres relative to present (0 m at 0 ka, negative = lower than today, see
:func:`unerode_cli.climate.chronology.parse_table` for the anchoring); δ18O in ‰.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from unerode_cli.climate.chronology import Series


@dataclass(frozen=True)
class SeaLevelMapping:
    """Linear map from benthic δ18O to sea level: sea(m) = intercept + slope · δ18O(‰).

    Attributes:
        slope: m per ‰ (negative: more δ18O = more ice = lower sea).
        intercept: m, the sea level at δ18O = 0 ‰ (a fit constant, not a physical level).
    """

    slope: float
    intercept: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.slope) and math.isfinite(self.intercept)):
            raise ValueError("the δ18O → sea-level mapping needs a finite slope and intercept")

    def __call__(self, d18o_permil: float | np.ndarray) -> float | np.ndarray:
        """Sea level (m relative to present) for δ18O values (‰), scalar or array."""
        out = self.intercept + self.slope * np.asarray(d18o_permil, dtype=np.float64)
        return float(out) if np.ndim(out) == 0 else out

    def d18o_for(self, sea_level_m: float) -> float:
        """The δ18O (‰) that maps to ``sea_level_m`` (m); needs a non-zero slope."""
        if self.slope == 0.0:
            raise ValueError("a δ18O → sea-level mapping with slope 0 cannot be inverted")
        return (float(sea_level_m) - self.intercept) / self.slope


#: Default δ18O → sea-level mapping: the least-squares fit (:func:`fit_mapping`) of the LR04
#: benthic δ18O stack (Lisiecki & Raymo 2005, ``lr04/LR04stack.txt``) to the Spratt & Lisiecki
#: 2016 sea-level stack (``SeaLev_longPC1``, anchored to 0 m at 0 ka), sampled at Spratt's
#: 799 ages 0–798 ka: slope −65.05 m/‰, intercept 209.35 m (residual RMS 14.7 m). With it, the
#: LR04 value at present (3.23 ‰) maps to +1.2 m and the LGM maximum (5.02 ‰, 18 ka) to −117 m.
#: (The same fit against Bintanja & van de Wal 2008 over 0–3000 ka gives −70.01 m/‰ and
#: 231.88 m, RMS 7.7 m.) ``tests/climate/test_sea_level_mapping.py`` recomputes both.
DEFAULT_MAPPING = SeaLevelMapping(slope=-65.0522, intercept=209.3450)


def fit_mapping(d18o: Series, sea: Series) -> SeaLevelMapping:
    """Least-squares linear fit sea = intercept + slope·δ18O on the ages the two series share.

    The δ18O series is interpolated at the sea-level series' own ages that fall inside both
    tables' ranges, and an ordinary least-squares line is fitted through those pairs.

    Args:
        d18o: benthic δ18O (‰) by age (ka).
        sea: sea level (m relative to present) by age (ka).

    Raises:
        ValueError: fewer than two shared ages, or a constant δ18O over them (one sentence).
    """
    inside = (sea.age_ka >= d18o.start_ka) & (sea.age_ka <= d18o.end_ka)
    ages = sea.age_ka[inside]
    if ages.size < 2:
        raise ValueError(
            f"the δ18O series ({d18o.start_ka:g}–{d18o.end_ka:g} ka) and the sea-level series "
            f"({sea.start_ka:g}–{sea.end_ka:g} ka) share fewer than two sea-level ages"
        )
    x = np.asarray(d18o.at(ages), dtype=np.float64)
    y = sea.value[inside]
    dx = x - x.mean()
    spread = float(np.sum(dx * dx))
    if spread == 0.0:
        raise ValueError("δ18O is constant over the ages shared with the sea-level series, so no line fits")
    slope = float(np.sum(dx * (y - y.mean())) / spread)
    return SeaLevelMapping(slope=slope, intercept=float(y.mean() - slope * x.mean()))


def sea_level(age_ka: float | np.ndarray, sea: Series | None = None, d18o: Series | None = None,
              mapping: SeaLevelMapping | None = None) -> float | np.ndarray:
    """Sea level (m relative to present) at ``age_ka`` (ka; scalar or array).

    From the sea-level table ``sea`` when it is given (linear interpolation); else from the δ18O
    table ``d18o`` through ``mapping`` (:data:`DEFAULT_MAPPING` when None).

    Raises:
        ValueError: neither table is given, or an age is outside the table used (one sentence).
    """
    if sea is not None:
        return sea.at(age_ka)
    if d18o is None:
        raise ValueError("sea level needs a sea-level table or a δ18O table, and neither was given")
    return (mapping or DEFAULT_MAPPING)(d18o.at(age_ka))
