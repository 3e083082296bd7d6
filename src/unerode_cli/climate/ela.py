"""The equilibrium-line altitude (ELA, the glacier model's E of 001 Eq. 2) through time, from a
paleo-climate chronology (DESIGN §7).

001 drives its glaciers by moving E alone: in the Fig. 6 scenario (001 §7) E is lowered from
3000 m to 1200 m over 100 ky of cooling, then rises to 1700 m in 20 ky of warming; 001 §7.4
notes that E "depends on the average temperature at sea level, which can vary by up to 10 °C
between glacial and interglacial periods"; 001 Table 1 gives E = 500–2000 m. Here E(age) follows
a real chronology instead, in one of two ways.

**Linear between present and the LGM** (:func:`ela_from_proxy`), for any proxy kind of
:data:`ELA_KINDS`::

    E(age) = E0 + (E_lgm − E0) · (P(age) − P(0)) / (P_lgm − P(0))

with P the proxy, P(0) its value at 0 ka (interpolated) and P_lgm its most glacial value in the
LGM window (:func:`lgm`), E0 the present ELA and E_lgm the ELA at the last glacial maximum
(m, both given by the user). Which way is glacial, per kind:

- ``"d18o"``: benthic δ18O (‰), heavier (larger) = colder, more ice (LR04 = Lisiecki & Raymo
  2005; its heaviest value near the LGM is 5.02 ‰ at 18 ka);
- ``"sea-level"``: sea level (m relative to present), lower = more ice = colder;
- ``"temperature"``: a temperature or temperature anomaly (K or °C: only differences are used),
  lower = colder.

So E = E0 at 0 ka exactly and E = E_lgm at the LGM's age. Beyond that range the line is
extrapolated, never clamped: a glacial colder than the LGM (e.g. an older glacial maximum
with heavier δ18O, e.g. MIS 12 in LR04, 5.08 ‰ at 433 ka) puts E below E_lgm, and an
interglacial warmer than today (e.g. MIS 5e in LR04, 3.10 ‰ at 123 ka against 3.23 ‰ at 0 ka)
puts E above E0, both in proportion to the proxy.

**From a temperature and a lapse rate** (:func:`ela_from_temperature`)::

    E(age) = E0 + L · (T(age) − T(0))

with L (m/K) how many metres the ELA rises per kelvin of warming (the ``--ela-lapse-rate``
option): the ELA is taken to follow an isotherm, which moves by ΔT/Γ with Γ the atmospheric
lapse rate (K/m), so L = 1/Γ, 1/0.0065 K/m ≈ 153.8 m/K for the standard atmosphere's 6.5 K/km
(ISO 2533). Colder (T(age) < T(0)) lowers the ELA: 10 K colder, 001 §7.4's glacial swing,
lowers it by ~1540 m. Precipitation changes are not modelled by this route.

Units: ages in ka (thousands of years before present), as the chronologies are written;
ELA in m; :func:`ela_table` turns ages into years since the start of a run for the glacier
model's time table. Pure functions: the chronology files are read by
``unerode_cli.io.chronology_files`` and ``unerode_cli.io.ela_files``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from unerode_cli.climate.chronology import YEARS_PER_KA, Series

#: Proxy kinds an ELA can follow, each with the direction of colder climate (see the module
#: docstring): +1 when a larger value is more glacial, −1 when a smaller one is.
COLDER: dict[str, float] = {"d18o": 1.0, "sea-level": -1.0, "temperature": -1.0}

#: The proxy kinds of :func:`lgm` and :func:`ela_from_proxy`.
ELA_KINDS: tuple[str, ...] = tuple(COLDER)

#: Where the last glacial maximum is looked for (ka): marine isotope stage 2, 14–29 ka in the
#: LR04 age model (Lisiecki & Raymo 2005, ``lr04/LR04_MISboundaries.txt``), to 30 ka. It holds
#: the global LGM of ~26.5–19 ka (Clark et al. 2009, Science 325, 710–714) and the most glacial
#: values of the shared chronologies: LR04 δ18O 5.02 ‰ at 18 ka, Spratt & Lisiecki 2016 sea level
#: at 24 ka, Bintanja & van de Wal 2008 sea level at 19.8 ka and temperature at 19.6 ka.
LGM_WINDOW_KA: tuple[float, float] = (14.0, 30.0)

#: Atmospheric lapse rate Γ of the standard atmosphere's troposphere (K/m): 6.5 K/km (ISO 2533).
STANDARD_LAPSE_RATE_K_PER_M = 0.0065

#: Default ELA shift per kelvin of warming (m/K): 1/Γ ≈ 153.8 m/K.
DEFAULT_ELA_M_PER_K = 1.0 / STANDARD_LAPSE_RATE_K_PER_M


def lgm(series: Series, kind: str, window_ka: tuple[float, float] = LGM_WINDOW_KA) -> tuple[float, float]:
    """The last glacial maximum of a proxy: (age in ka, proxy value in the series' unit) of its
    most glacial sample (heaviest δ18O, lowest sea level, coldest temperature: :data:`COLDER`)
    inside ``window_ka``; the youngest one when several are equal.

    The window is cut to the ages the series covers. Its ends count as well (the curve is
    linear between samples): when the curve is more glacial at one end of the window than at
    every sample inside, the window holds no glacial maximum and is refused.

    Args:
        series: the proxy by age (ka).
        kind: one of :data:`ELA_KINDS`.
        window_ka: (youngest, oldest) age of the window, ka.

    Raises:
        ValueError: unknown kind, a window that is not two increasing finite ages, a series
            outside the window, or a most glacial value at an end of the window (one sentence).
    """
    colder = _colder(kind)
    young, old = (float(age) for age in window_ka)
    if not (math.isfinite(young) and math.isfinite(old) and young < old):
        raise ValueError(f"the LGM window must be two finite ages in ka, youngest first, got {window_ka!r}")
    young, old = max(young, series.start_ka), min(old, series.end_ka)
    if not young < old:
        raise ValueError(
            f"the chronology {series.name!r} ({series.start_ka:g}–{series.end_ka:g} ka) does not reach "
            f"into the LGM window {window_ka[0]:g}–{window_ka[1]:g} ka"
        )
    inside = (series.age_ka > young) & (series.age_ka < old)
    glacial = colder * series.value[inside]
    ends = colder * np.asarray(series.at(np.array([young, old])))
    if not glacial.size or ends.max() > glacial.max():
        raise ValueError(
            f"the chronology {series.name!r} is most glacial at an end of the LGM window "
            f"{young:g}–{old:g} ka, so the window holds no glacial maximum; move or widen it"
        )
    k = int(np.argmax(glacial))
    return float(series.age_ka[inside][k]), float(series.value[inside][k])


def ela_from_proxy(series: Series, kind: str, present_m: float, glacial_m: float, ages_ka: ArrayLike,
                   window_ka: tuple[float, float] = LGM_WINDOW_KA) -> np.ndarray:
    """ELA (m) at ``ages_ka``, linear in the proxy between present (``present_m`` at 0 ka) and
    the LGM of :func:`lgm` (``glacial_m``), extrapolated beyond (module docstring).

    Args:
        series: the proxy by age (ka); it must cover 0 ka and ``ages_ka``.
        kind: one of :data:`ELA_KINDS`.
        present_m: E0, the ELA today (m).
        glacial_m: E_lgm, the ELA at the LGM (m), below ``present_m``.
        ages_ka: ages (ka), any shape.
        window_ka: the LGM window of :func:`lgm` (ka).

    Returns:
        float64 array of the shape of ``ages_ka``, m.

    Raises:
        ValueError: non-finite ELAs or ``glacial_m`` ≥ ``present_m``, an age outside the series,
            an LGM not found (:func:`lgm`) or no more glacial than present (one sentence).
    """
    if not (math.isfinite(present_m) and math.isfinite(glacial_m) and glacial_m < present_m):
        raise ValueError(
            f"the glacial ELA must be a finite altitude below the present one, got {glacial_m:g} m "
            f"at the LGM and {present_m:g} m today"
        )
    values = np.asarray(series.at(ages_ka), dtype=np.float64)
    now = float(series.at(0.0))
    age, peak = lgm(series, kind, window_ka)
    if not COLDER[kind] * (peak - now) > 0.0:
        raise ValueError(
            f"the chronology {series.name!r} is not more glacial at its LGM ({age:g} ka, {peak:g}) "
            f"than at present ({now:g}), so it cannot place the glacial ELA"
        )
    return present_m + (glacial_m - present_m) * (values - now) / (peak - now)


def ela_from_temperature(series: Series, lapse_rate_m_per_k: float, present_m: float,
                         ages_ka: ArrayLike) -> np.ndarray:
    """ELA (m) at ``ages_ka`` that follows the temperature: E0 + L · (T(age) − T(0)), so a
    colder past (T(age) < T(0)) has a lower ELA (module docstring).

    Args:
        series: a temperature or temperature anomaly by age (ka), in K or °C (only differences
            are used); it must cover 0 ka and ``ages_ka``.
        lapse_rate_m_per_k: L, metres the ELA rises per kelvin of warming (m/K, > 0): 1/Γ with
            Γ the atmospheric lapse rate, :data:`DEFAULT_ELA_M_PER_K` ≈ 153.8 m/K for 6.5 K/km.
        present_m: E0, the ELA today (m).
        ages_ka: ages (ka), any shape.

    Returns:
        float64 array of the shape of ``ages_ka``, m.

    Raises:
        ValueError: a lapse rate that is not a finite positive number, a non-finite ELA, or an
            age outside the series (one sentence).
    """
    if not (math.isfinite(lapse_rate_m_per_k) and lapse_rate_m_per_k > 0.0):
        raise ValueError(
            f"the ELA lapse rate must be a finite positive number of m per K, got {lapse_rate_m_per_k:g}"
        )
    if not math.isfinite(present_m):
        raise ValueError(f"the present ELA must be a finite altitude in m, got {present_m:g}")
    values = np.asarray(series.at(ages_ka), dtype=np.float64)
    return present_m + lapse_rate_m_per_k * (values - float(series.at(0.0)))


def ela_table(ages_ka: ArrayLike, ela_m: ArrayLike, from_ka: float, to_ka: float,
              source: str = "the ELA chronology") -> tuple[np.ndarray, np.ndarray]:
    """The ELA of a run forward in time from age ``from_ka`` to the younger ``to_ka``, as the
    glacier model's time table: (times in years since the start of the run, ELA in m).

    Times are t = (``from_ka`` − age) · 1000 y, so t = 0 at ``from_ka`` and t = (``from_ka`` −
    ``to_ka``) · 1000 y at ``to_ka``. The table holds both ends (ELA interpolated linearly) and
    every sample strictly between them; both arrays are float64, times strictly increasing.

    Args:
        ages_ka: sample ages (ka), strictly ascending, at least two (e.g. ``series.age_ka``).
        ela_m: the ELA at those ages (m), e.g. from :func:`ela_from_proxy`.
        from_ka: the run's first (oldest) age, ka.
        to_ka: the run's last (youngest) age, ka, younger than ``from_ka``.
        source: how to name the chronology in error messages (e.g. its path).

    Raises:
        ValueError: malformed samples, ``from_ka`` ≤ ``to_ka``, or run ages the samples do not
            span (one sentence naming both ranges).
    """
    ela = Series(ages_ka, ela_m, name=source, unit="m")
    if not from_ka > to_ka:
        raise ValueError(
            f"a run goes forward in time from an older age to a younger one, but it goes from "
            f"{from_ka:g} ka to {to_ka:g} ka"
        )
    if not ela.covers(np.array([to_ka, from_ka])):
        raise ValueError(
            f"{source} covers {ela.start_ka:g}–{ela.end_ka:g} ka, which does not span the run "
            f"from {from_ka:g} ka to {to_ka:g} ka"
        )
    ages = ela.age_ka[::-1]
    times = (from_ka - ages) * YEARS_PER_KA
    end = (from_ka - to_ka) * YEARS_PER_KA
    inside = (times > 0.0) & (times < end)
    ends = np.asarray(ela.at(np.array([from_ka, to_ka])))
    return (np.concatenate(([0.0], times[inside], [end])),
            np.concatenate((ends[:1], ela.value[::-1][inside], ends[1:])))


def _colder(kind: str) -> float:
    """+1 or −1: the sign of a more glacial value of proxy ``kind`` (:data:`COLDER`)."""
    if kind not in COLDER:
        raise ValueError(f"unknown ELA proxy kind {kind!r}; use one of {', '.join(ELA_KINDS)}")
    return COLDER[kind]
