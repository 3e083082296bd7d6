"""Climate phases from sea level: glacial, end of glacial, interglacial (000 §5.1, Table 1).

000 §5.1 splits each ~100 kyr cycle of the last 800 kyr into three phases, each with its own
mix of erosion processes (000 Table 1):

- **glacial** (beginning and maximum; ~80 kyr): slow cooling, sea level falls by up to ~150 m;
  freeze/thaw → strong thermal erosion upstream, low sea level → fluvial incision downstream;
- **end of glacial** ("approximately the last 10 kyr of a glacial period"): rapid warming, sea
  level rises fast; reduced thermal erosion, loss of stream strength → fluvial deposition;
- **interglacial** (~20 kyr): high sea level, forests; little thermal erosion, downstream
  sedimentation.

The paper gives no numbers for where a phase starts, so this module turns those sentences into
a rule on a sea-level curve (the quantity that 000 §5.2 ties the parameters to):

1. **interglacial**: sea level ≥ ``interglacial_sea_level_m`` (default −35 m relative to
   present);
2. **end of glacial**: not interglacial, at most ``end_window_kyr`` (default 10 kyr, 000 §5.1.2)
   older than the onset of the next (younger) interglacial, and sea level rising toward the
   present at ≥ ``min_rise_rate_m_per_kyr`` (default 2 m/kyr) at every sample between it and
   that onset (the rapid-warming run that ends at the onset; rates are centred differences);
3. **glacial**: everything else — including a rise that does not reach interglacial level
   within the samples given (no onset ahead, e.g. a series that ends mid-deglaciation).

Why these defaults: with Spratt & Lisiecki 2016 (anchored to 0 m at 0 ka) sampled every 1 kyr,
the rule gives 0–10 ka interglacial (10 ka: −32 m), 11–18 ka end of glacial (Termination I:
18→11 ka rises from −123 to −45 m at 4–15 m/kyr), 19–82 ka glacial (LGM, MIS 2–4), MIS 5e
(116–126 ka) interglacial, an end of glacial at each of the terminations of LR04's MIS
boundaries 1/2, 5/6, 7/8, 9/10, 11/12 and 15/16, and 24 % of 0–798 ka interglacial, 11 % end
of glacial, close to 000 §5.1's "~20 kyr in 100". The threshold −35 m is the highest that
still counts 10 ka as interglacial with a few metres of margin (it also makes the MIS 5c
high stand at 96–101 ka a short interglacial); the rate 2 m/kyr separates the LGM plateau
(|rate| < 1.3 m/kyr at 19–21 ka) from the deglaciation. The same rule gives the same Holocene,
Termination I and LGM on Bintanja & van de Wal 2008, and on LR04 δ18O mapped with the default
linear mapping: 0–11 ka interglacial, 12–18 ka end of glacial, 19+ ka glacial (δ18O is
noisier, so the later terminations are found less regularly there).

δ18O form: :func:`classify_d18o` maps δ18O (‰) to sea level with a
:class:`~unerode_cli.climate.sealevel.SeaLevelMapping` and applies the same rule; the
equivalent δ18O thresholds are given by :meth:`PhaseThresholds.interglacial_d18o_permil` and
:meth:`PhaseThresholds.min_d18o_fall_rate_permil_per_kyr` (default mapping: interglacial when
δ18O ≤ 3.76 ‰, end of glacial when δ18O falls by ≥ 0.031 ‰/kyr).

Units: ages in ka (thousands of years before present) — these table functions work in ka by
nature; sea level in metres relative to present; rates in m per kyr (1 m/kyr = 0.001 m/y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from unerode_cli.climate.sealevel import DEFAULT_MAPPING, SeaLevelMapping

GLACIAL = "glacial"
END_OF_GLACIAL = "end-of-glacial"
INTERGLACIAL = "interglacial"
#: The phases, coldest first.
PHASES: tuple[str, ...] = (GLACIAL, END_OF_GLACIAL, INTERGLACIAL)


@dataclass(frozen=True)
class PhaseThresholds:
    """Where the phases start (see the module docstring for the rule and the defaults' reasons).

    Attributes:
        interglacial_sea_level_m: interglacial when sea level ≥ this (m relative to present).
        end_window_kyr: the end of glacial is at most this long before an interglacial onset
            (kyr; 000 §5.1.2: "approximately the last 10kyr").
        min_rise_rate_m_per_kyr: sea level must rise toward the present at least this fast
            (m/kyr) through the end of glacial.
    """

    interglacial_sea_level_m: float = -35.0
    end_window_kyr: float = 10.0
    min_rise_rate_m_per_kyr: float = 2.0

    def __post_init__(self) -> None:
        for name in ("interglacial_sea_level_m", "end_window_kyr", "min_rise_rate_m_per_kyr"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"phase threshold {name} must be a finite number, got {value!r}")
        if self.end_window_kyr <= 0.0:
            raise ValueError(f"phase threshold end_window_kyr must be > 0 kyr, got {self.end_window_kyr:g}")
        if self.min_rise_rate_m_per_kyr < 0.0:
            raise ValueError(
                "phase threshold min_rise_rate_m_per_kyr must be ≥ 0 m/kyr, "
                f"got {self.min_rise_rate_m_per_kyr:g}"
            )

    def interglacial_d18o_permil(self, mapping: SeaLevelMapping = DEFAULT_MAPPING) -> float:
        """The δ18O (‰) at which ``mapping`` gives the interglacial sea level (interglacial at
        or below it for the usual negative slope)."""
        return mapping.d18o_for(self.interglacial_sea_level_m)

    def min_d18o_fall_rate_permil_per_kyr(self, mapping: SeaLevelMapping = DEFAULT_MAPPING) -> float:
        """The rate (‰/kyr) at which δ18O must fall toward the present through the end of
        glacial, under ``mapping``."""
        if mapping.slope == 0.0:
            raise ValueError("a δ18O → sea-level mapping with slope 0 cannot be inverted")
        return self.min_rise_rate_m_per_kyr / abs(mapping.slope)


def classify(ages_ka: np.ndarray, sea_levels_m: np.ndarray,
             thresholds: PhaseThresholds | None = None) -> np.ndarray:
    """Phase of each sample of a sea-level curve (rule in the module docstring).

    Args:
        ages_ka: sample ages (ka), 1-D, distinct, in any order.
        sea_levels_m: sea level at those ages (m relative to present), same shape.
        thresholds: the rule's thresholds; None for the defaults.

    Returns:
        A string array (same order as ``ages_ka``) of :data:`GLACIAL`, :data:`END_OF_GLACIAL`
        and :data:`INTERGLACIAL`. Sample the curve densely enough (≈1 kyr) for the rates to mean
        something: the end of glacial is found from the samples given, not from a table.

    Raises:
        ValueError: shapes differ, empty input, non-finite values or repeated ages (one sentence).
    """
    t = thresholds or PhaseThresholds()
    ages = np.asarray(ages_ka, dtype=np.float64)
    sea = np.asarray(sea_levels_m, dtype=np.float64)
    if ages.ndim != 1 or ages.shape != sea.shape:
        raise ValueError(
            f"classify needs two 1-D arrays of the same length, got shapes {ages.shape} and {sea.shape}"
        )
    if ages.size == 0:
        raise ValueError("classify needs at least one age")
    if not (np.all(np.isfinite(ages)) and np.all(np.isfinite(sea))):
        raise ValueError("classify needs finite ages and sea levels (NaN or infinity found)")
    order = np.argsort(ages, kind="stable")
    a, s = ages[order], sea[order]
    if np.any(np.diff(a) == 0.0):
        raise ValueError(f"classify got the age {a[np.flatnonzero(np.diff(a) == 0.0)[0]]:g} ka twice")
    n = a.size
    interglacial = s >= t.interglacial_sea_level_m
    # rise toward the present (younger = smaller age): −d(sea)/d(age), m/kyr
    rise = -np.gradient(s, a) if n > 1 else np.zeros(1)
    index = np.arange(n)
    onset = np.maximum.accumulate(np.where(interglacial, index, -1))  # nearest younger interglacial
    stall = np.maximum.accumulate(np.where(rise < t.min_rise_rate_m_per_kyr, index, -1))
    has_onset = onset >= 0
    near = np.zeros(n, dtype=bool)
    near[has_onset] = a[has_onset] - a[onset[has_onset]] <= t.end_window_kyr
    end = ~interglacial & has_onset & near & (stall <= onset)
    phase = np.where(interglacial, INTERGLACIAL, np.where(end, END_OF_GLACIAL, GLACIAL))
    out = np.empty(n, dtype=phase.dtype)
    out[order] = phase
    return out.astype(f"<U{max(len(p) for p in PHASES)}")


def classify_d18o(ages_ka: np.ndarray, d18o_permil: np.ndarray, thresholds: PhaseThresholds | None = None,
                  mapping: SeaLevelMapping = DEFAULT_MAPPING) -> np.ndarray:
    """Phases from a δ18O curve (‰) when no sea-level curve is given: δ18O is mapped to sea
    level with ``mapping`` and :func:`classify` is applied (same arguments and result)."""
    return classify(ages_ka, np.asarray(mapping(np.asarray(d18o_permil, dtype=np.float64))), thresholds)
