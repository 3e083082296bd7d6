"""Sea level through time: from a sea-level table, or from benthic δ18O scaled linearly.

000 §5.1–5.2: sea level falls by up to ~150 m in glacial periods; the downstream deposition
coefficient K_d and the Dirichlet boundary nodes follow it. A sea-level reconstruction (e.g.
Spratt & Lisiecki 2016) is used directly when given; when only a δ18O stack (LR04) is given,
sea level is taken as a linear function of δ18O (DESIGN §7):

    sea(m) = intercept + slope · δ18O(‰)

That is a first-order approximation: benthic δ18O mixes ice volume (sea level) with deep-water
temperature, so the linear map reproduces the large glacial–interglacial swings (tens of
metres of error at some ages), not the details.

**A sea-level table extended with δ18O** (:func:`extend_with_d18o`): where a run is older than
the table's oldest age (Spratt & Lisiecki 2016 ends at 798 ka), the table is continued with
sea level from δ18O through the least-squares line of the table against δ18O over their
overlap (:func:`fit_mapping`), and the table's residual at its oldest age is carried across the
join and tapered linearly to zero over ``taper_ka`` (default 10 ka), so that the curve is
continuous there. For LR04 and Spratt 2016 (0–798 ka, 799 pairs): sea = 209.35 m − 65.052 m/‰
· δ18O, residual RMS 14.67 m; the residual at 798 ka is −6.23 m (table −101.33 m, line
−95.10 m), so the extension starts at −101.33 m and meets the line at 808 ka.

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


#: How far past the join the table's last residual is carried onto the δ18O line (ka).
JOIN_TAPER_KA = 10.0


def residual_rms(d18o: Series, sea: Series, mapping: SeaLevelMapping) -> float:
    """RMS (m) of ``sea`` minus ``mapping``(δ18O) at the sea-level ages inside both tables."""
    inside = (sea.age_ka >= d18o.start_ka) & (sea.age_ka <= d18o.end_ka)
    residual = sea.value[inside] - np.asarray(mapping(d18o.at(sea.age_ka[inside])))
    return float(np.sqrt(np.mean(residual * residual)))


def extend_with_d18o(sea: Series, d18o: Series, taper_ka: float = JOIN_TAPER_KA) -> Series:
    """``sea`` (m) continued beyond its oldest age with sea level from ``d18o`` (‰).

    Beyond the join age a_j (the table's oldest age), at the δ18O table's own ages up to its
    oldest::

        sea(a) = M(δ18O(a)) + r_j · max(0, 1 − (a − a_j) / taper_ka)

    where M is the least-squares line of the table against δ18O over their overlap
    (:func:`fit_mapping`) and r_j = sea(a_j) − M(δ18O(a_j)) the table's residual at the join.
    The table's own sample at a_j is kept, so the curve is continuous there (the first step
    past it is that of the line plus the tapered residual). Within the table's range the values
    are the table's. A table that already reaches the δ18O table's oldest age is
    returned as it is. The series' ``note`` states the line, its residual RMS and the join.

    Args:
        sea: sea level (m relative to present) by age (ka).
        d18o: benthic δ18O (‰) by age (ka), covering the join age.
        taper_ka: ka over which the join residual goes to zero (> 0).

    Raises:
        ValueError: ``taper_ka`` ≤ 0, the δ18O table does not cover the join age, or the two
            share fewer than two ages (one sentence).
    """
    if not (math.isfinite(taper_ka) and taper_ka > 0.0):
        raise ValueError(f"the taper of the sea-level join must be a positive number of ka, got {taper_ka:g}")
    join = sea.end_ka
    if d18o.end_ka <= join:
        return sea
    if not d18o.covers(join):
        raise ValueError(f"the δ18O table ({d18o.start_ka:g}–{d18o.end_ka:g} ka) does not reach the end "
                         f"of the sea-level table at {join:g} ka, so it cannot extend it")
    mapping = fit_mapping(d18o, sea)
    residual = float(sea.value[-1]) - float(mapping(d18o.at(join)))
    ages = d18o.age_ka[d18o.age_ka > join]
    taper = np.maximum(0.0, 1.0 - (ages - join) / taper_ka)
    values = np.asarray(mapping(d18o.at(ages))) + residual * taper
    note = (f"{sea.note + '; ' if sea.note else ''}beyond {join:g} ka: sea = {mapping.intercept:.2f} m "
            f"{mapping.slope:+.3f} m/‰ × δ18O (fit over the overlap, residual RMS "
            f"{residual_rms(d18o, sea, mapping):.2f} m), the join residual {residual:+.2f} m tapered "
            f"to 0 over {taper_ka:g} ka")
    return Series(np.concatenate((sea.age_ka, ages)), np.concatenate((sea.value, values)),
                  sea.name, sea.unit, note, sea.changes)


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
