"""Parameter schedule: process parameters per climate phase and a downstream K_d that follows
sea level (000 §5.2, Table 1).

000 §5.2: "the thermal erosion coefficient K_th is increased in glacial periods from 0.002 to
0.008 ... The sedimentation coefficient K_d is tuned in downstream regions to follow sea level
(while sea level fluctuates by 150 meters, K_d fluctuates from 0.1 to 3). The precipitation
rate p is lowered in glacial periods (from 0.6 to 0.3 m/year)". Defaults here:

- ``k_th`` (m/ky, the unit of 000 Table 2, see ``processes.thermal``): interglacial 0.002, end
  of glacial 0.005, glacial 0.008;
- ``precipitation`` (m/y): interglacial 0.6, end of glacial 0.45, glacial 0.3.

The end-of-glacial values are our choice (the paper gives none): midway, because 000 Table 1
says thermal phenomena are "reduced" at the end of glacials and the climate is warming
(wetter) toward the interglacial.

Downstream K_d (m/y, the project's ``k_d``): linear in sea level s (m relative to present),
clamped to the range, from ``present`` at s ≥ 0 to ``lowest`` at s ≤ −``range_m``::

    k_d(s) = present + (lowest − present) · clip(−s / range_m, 0, 1)

defaults 3 at present sea level → 0.1 at 150 m below (000 §5.2: "while sea level fluctuates by
150 meters, K_d fluctuates from 0.1 to 3"). The direction is 000 Table 1's: at high sea level
(interglacials) rivers lose stream strength and deposit ("deposition of sediments"), so K_d is
high; at the glacial lowstand they incise and the "high erosion rate prevents deposition"
(§5.1.1), so K_d is low. It applies only inside a downstream region chosen by
the caller (:func:`downstream_mask`); elsewhere ``k_d`` keeps its ordinary value (the run's
``k_d`` or the phase's, when a phase sets one). Note: 000 gives K_d without a unit; the project's
``k_d`` is in m/y (Yuan et al. 2019's G times the mean precipitation, DESIGN §6), and these
numbers are used as they are.

Schedule mapping (``Schedule.from_mapping``; the YAML file is read by the pipeline)::

    glacial:            {k_th: 0.01, precipitation: 0.25}
    end-of-glacial:     {k_th: 0.006}
    interglacial:       {k: 2.0e-5}            # a parameter the defaults do not set
    downstream_k_d:     {present: 3, lowest: 0.1, range_m: 150}

Every key is optional; a value given replaces the default of that phase only; a parameter not
set for a phase keeps the run's ordinary value in that phase. Parameter names are the
project's (``k_th``, ``precipitation``, ``k_d``, ``k``, ``uplift``…) or the papers' symbols
``K_th``, ``p``, ``K_d``, ``K``, ``U``.

How a phase's value meets the run's own (``Schedule.apply``): a number is replaced by the
phase's value; a raster (a map of the parameter, e.g. K_th varying with the rock) is taken as
the present-day, interglacial field and scaled by the phase's value relative to the
interglacial one, so that its pattern survives every phase (000 §6: parameters "can vary in
space and time")::

    v(x, phase) = raster(x) · v_phase / v_interglacial

e.g. a K_th raster in a glacial step is multiplied by 0.008 / 0.002 = 4 and a precipitation
raster by 0.3 / 0.6 = 0.5. A phase that sets a parameter the interglacial does not set (or sets
to 0) gives a raster of it nothing to be scaled from, and is refused.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from unerode_cli.climate.phases import END_OF_GLACIAL, GLACIAL, INTERGLACIAL, PHASES

#: Key of the downstream K_d in :meth:`Schedule.values` and in the schedule mapping.
DOWNSTREAM_K_D = "downstream_k_d"

#: The papers' symbols accepted as parameter names in a schedule mapping.
ALIASES: dict[str, str] = {"K_th": "k_th", "p": "precipitation", "K_d": "k_d", "K": "k", "U": "uplift"}

#: Parameters that must not be negative (rates and coefficients).
NON_NEGATIVE: frozenset[str] = frozenset({"k_th", "precipitation", "k_d", "k"})

#: Default per-phase values (000 §5.2; end of glacial: midway, our choice); k_th in m/ky.
DEFAULT_PHASE_VALUES: dict[str, dict[str, float]] = {
    GLACIAL: {"k_th": 0.008, "precipitation": 0.3},
    END_OF_GLACIAL: {"k_th": 0.005, "precipitation": 0.45},
    INTERGLACIAL: {"k_th": 0.002, "precipitation": 0.6},
}


@dataclass(frozen=True)
class DownstreamKd:
    """Downstream K_d following sea level, clamped (000 §5.2, in the direction of Table 1).

    Attributes:
        present: k_d at present sea level or higher (m/y): interglacial deposition.
        lowest: k_d at ``range_m`` below present or lower (m/y): glacial incision.
        range_m: the sea-level fall over which k_d goes from ``present`` to ``lowest`` (m, > 0).
    """

    present: float = 3.0
    lowest: float = 0.1
    range_m: float = 150.0

    def __post_init__(self) -> None:
        for name in ("present", "lowest", "range_m"):
            value = getattr(self, name)
            if not _is_number(value):
                raise ValueError(f"{DOWNSTREAM_K_D}.{name} must be a finite number, got {value!r}")
            if value < 0.0 or (name == "range_m" and value == 0.0):
                bound = "> 0 m" if name == "range_m" else "≥ 0 m/y"
                raise ValueError(f"{DOWNSTREAM_K_D}.{name} must be {bound}, got {value:g}")

    def at(self, sea_level_m: float | np.ndarray) -> float | np.ndarray:
        """k_d (m/y) at sea level ``sea_level_m`` (m relative to present; scalar or array)."""
        fall = np.clip(-np.asarray(sea_level_m, dtype=np.float64) / self.range_m, 0.0, 1.0)
        out = self.present + (self.lowest - self.present) * fall
        return float(out) if np.ndim(out) == 0 else out


@dataclass(frozen=True)
class Schedule:
    """Process parameters per climate phase, and the downstream K_d (see the module docstring).

    Attributes:
        phases: phase name → {parameter name: value in the parameter's declared unit}.
        downstream: the downstream K_d rule.
    """

    phases: Mapping[str, Mapping[str, float]] = field(
        default_factory=lambda: {p: dict(v) for p, v in DEFAULT_PHASE_VALUES.items()})
    downstream: DownstreamKd = field(default_factory=DownstreamKd)

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any] | None) -> Schedule:
        """The default schedule with the values of ``mapping`` (format in the module docstring)
        put over it.

        Raises:
            ValueError: an unknown key, a phase that is not a mapping, a value that is not a
                finite number, or a negative rate (one sentence naming the key).
        """
        if mapping is None:
            return cls()
        if not isinstance(mapping, Mapping):
            raise ValueError(
                f"a schedule must be a mapping of phases to parameters, got {type(mapping).__name__}"
            )
        phases = {p: dict(v) for p, v in DEFAULT_PHASE_VALUES.items()}
        downstream = DownstreamKd()
        for key, item in mapping.items():
            if key == DOWNSTREAM_K_D:
                downstream = _downstream(item)
            elif key in PHASES:
                if item is None:
                    continue
                if not isinstance(item, Mapping):
                    raise ValueError(
                        f"schedule key {key!r} must hold a mapping of parameter names to numbers"
                    )
                for name, value in item.items():
                    own = ALIASES.get(name, name) if isinstance(name, str) else name
                    if not isinstance(own, str) or not own.isidentifier():
                        raise ValueError(f"schedule key {key}.{name!r} is not a parameter name")
                    if own == DOWNSTREAM_K_D:
                        raise ValueError(
                            f"schedule key {key}.{name} is not per phase; give it at the top level"
                        )
                    if not _is_number(value):
                        raise ValueError(f"schedule key {key}.{name} must be a finite number, got {value!r}")
                    if own in NON_NEGATIVE and value < 0:
                        raise ValueError(f"schedule key {key}.{name} must be ≥ 0, got {value:g}")
                    phases[key][own] = float(value)
            else:
                raise ValueError(
                    f"unknown schedule key {key!r}; use {', '.join(PHASES)} or {DOWNSTREAM_K_D}"
                )
        return cls(phases, downstream)

    def to_mapping(self) -> dict[str, Any]:
        """The schedule as a mapping that :meth:`from_mapping` reads back (for provenance)."""
        return {**{p: dict(self.phases[p]) for p in PHASES},
                DOWNSTREAM_K_D: {"present": self.downstream.present, "lowest": self.downstream.lowest,
                                 "range_m": self.downstream.range_m}}

    def values(self, phase: str, sea_level_m: float) -> dict[str, float]:
        """Scalar parameter values for a step in ``phase`` at sea level ``sea_level_m`` (m).

        Returns the parameters the schedule sets for that phase (name → value in the
        parameter's declared unit; a parameter absent keeps the run's ordinary value), plus
        :data:`DOWNSTREAM_K_D` → :meth:`downstream_k_d` (m/y), which is not a process parameter:
        it replaces ``k_d`` inside the downstream region only.

        Raises:
            ValueError: unknown phase or non-finite sea level (one sentence).
        """
        return {**self._phase(phase), DOWNSTREAM_K_D: self.downstream_k_d(sea_level_m)}

    def factor(self, name: str, phase: str) -> float:
        """How much a present-day raster of parameter ``name`` is scaled in ``phase``:
        v_phase / v_interglacial, 1 where the phase does not set ``name`` or sets the
        interglacial value (module docstring).

        Raises:
            ValueError: unknown phase, or the phase sets ``name`` but the interglacial sets no
                non-zero value of it (one sentence).
        """
        own = self._phase(phase).get(name)
        present = self.phases[INTERGLACIAL].get(name)
        if own is None or own == present:
            return 1.0
        if not present:
            raise ValueError(
                f"the schedule sets {name} for {phase} but no non-zero value for {INTERGLACIAL}, so "
                f"a raster of {name} (the present-day field) has nothing to be scaled from; "
                f"give {INTERGLACIAL}: {{{name}: VALUE}}")
        return own / present

    def apply(self, phase: str, ordinary: Mapping[str, float | np.ndarray]) -> dict[str, float | np.ndarray]:
        """The run's parameters in ``phase``: ``ordinary`` (name → number or raster, in the
        parameter's declared unit) with the phase's values put over it, a number replaced and a
        raster scaled by :meth:`factor` (module docstring).

        Raises:
            ValueError: as :meth:`factor`, for a raster only.
        """
        out = dict(ordinary)
        for name, value in self._phase(phase).items():
            if name in out:
                out[name] = value if np.ndim(out[name]) == 0 else out[name] * self.factor(name, phase)
        return out

    def _phase(self, phase: str) -> Mapping[str, float]:
        """The values ``phase`` sets; ValueError (one sentence) for an unknown phase."""
        if phase not in PHASES:
            raise ValueError(f"unknown climate phase {phase!r}; use one of {', '.join(PHASES)}")
        return self.phases[phase]

    def downstream_k_d(self, sea_level_m: float) -> float:
        """k_d (m/y) of the downstream region at sea level ``sea_level_m`` (m relative to
        present): linear from ``present`` (0 m and above) to ``lowest`` (``range_m`` below and
        lower), 000 §5.2."""
        if not _is_number(sea_level_m):
            raise ValueError(f"sea level must be a finite number of metres, got {sea_level_m!r}")
        return float(self.downstream.at(float(sea_level_m)))


def downstream_mask(elevation: np.ndarray, below_m: float | None = None,
                    mask: np.ndarray | None = None) -> np.ndarray:
    """The downstream region where K_d follows sea level (000 §5.2), as bool[ny, nx].

    Give exactly one of:
        below_m: cells whose elevation (m) is strictly below this level (NaN cells excluded);
        mask: a given region (any array of ``elevation``'s shape; non-zero / True = inside).

    Raises:
        ValueError: neither or both given, a non-finite level, or a shape mismatch (one sentence).
    """
    h = np.asarray(elevation)
    if h.ndim != 2:
        raise ValueError(f"the elevation must be a 2-D grid, got shape {h.shape}")
    if (below_m is None) == (mask is None):
        raise ValueError("the downstream region needs exactly one of an elevation level or a mask")
    if mask is not None:
        region = np.asarray(mask)
        if region.shape != h.shape:
            raise ValueError(f"the downstream mask has shape {region.shape}, the elevation has {h.shape}")
        return region.astype(bool)
    if not _is_number(below_m):
        raise ValueError(f"the downstream elevation level must be a finite number of metres, got {below_m!r}")
    with np.errstate(invalid="ignore"):
        return np.asarray(h < float(below_m), dtype=bool)


def _downstream(item: Any) -> DownstreamKd:
    if not isinstance(item, Mapping):
        raise ValueError(f"schedule key {DOWNSTREAM_K_D!r} must hold a mapping with present, lowest, range_m")
    unknown = [k for k in item if k not in ("present", "lowest", "range_m")]
    if unknown:
        raise ValueError(
            f"unknown schedule key {DOWNSTREAM_K_D}.{unknown[0]}; use present, lowest or range_m"
        )
    defaults = DownstreamKd()
    values = {k: item.get(k, getattr(defaults, k)) for k in ("present", "lowest", "range_m")}
    for k, v in values.items():
        if not _is_number(v):
            raise ValueError(f"{DOWNSTREAM_K_D}.{k} must be a finite number, got {v!r}")
    return DownstreamKd(**{k: float(v) for k, v in values.items()})


def _is_number(value: Any) -> bool:
    return (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
            and math.isfinite(float(value)))
