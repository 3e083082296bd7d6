"""Sweeps of parameters: which values each member of an ensemble takes.

A sweep names parameters (opaque keys here) and, for each, either a **list** of values (every
value is tried: the lists form a full grid, numbers and text alike, e.g. two sea-level files) or
a **distribution** sampled by Latin hypercube (McKay, Beckman & Conover 1979):

* ``uniform: [low, high]`` — uniform on [low, high];
* ``log-uniform: [low, high]`` — log(value) uniform, 0 < low < high (rate constants);
* ``normal: [mean, sd]`` — Gaussian, sd > 0;
* ``choice: [a, b, ...]`` — one of the values, each equally likely (a sampled categorical).

With N samples, each sampled parameter's [0, 1) probability range is cut into N equal strata and
every stratum is hit exactly once: sample j of parameter i lies in stratum π_i(j), π_i a random
permutation, at a uniform random place inside it; the value is the distribution's quantile
there. The N samples are crossed with every combination of the lists (the same N samples for
each, so that e.g. two sea-level curves are compared on the same draws of the rates); with
lists only, the members are the grid. The same seed gives the same members. A sweep of more
than :data:`MAX_MEMBERS` members is refused before any member (or sample) is made.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

Value = str | int | float | bool
Kind = Literal["uniform", "log-uniform", "normal", "choice"]
DISTRIBUTIONS: tuple[Kind, ...] = ("uniform", "log-uniform", "normal", "choice")
#: The most members a sweep may have: each is a folder of outputs and a task, and their
#: parameters are held in memory and in ensemble.json.
MAX_MEMBERS = 100_000


@dataclass(frozen=True)
class Listed:
    """A parameter that takes each of ``values`` in turn (a grid axis)."""

    key: str
    values: tuple[Value, ...]


@dataclass(frozen=True)
class Sampled:
    """A parameter drawn from a distribution (``kind`` with its ``bounds``: low/high, or
    mean/sd for ``normal``; the categories for ``choice``)."""

    key: str
    kind: Kind
    bounds: tuple[Value, ...]

    def quantile(self, u: np.ndarray) -> list[Value]:
        """The values at probabilities ``u`` in [0, 1) (inverse cumulative distribution)."""
        if self.kind == "choice":
            return [self.bounds[int(i)] for i in np.floor(u * len(self.bounds))]
        a, b = (float(v) for v in self.bounds)
        if self.kind == "uniform":
            values = a + u * (b - a)
        elif self.kind == "log-uniform":
            values = np.exp(math.log(a) + u * (math.log(b) - math.log(a)))
        else:
            from scipy.special import ndtri

            values = a + b * ndtri(u)
        return [float(v) for v in values]


Parameter = Listed | Sampled


def parse_parameter(key: str, raw: Any) -> Parameter:
    """One entry of a sweep: a list (``Listed``) or a one-key mapping ``{kind: [a, b]}``
    (``Sampled``). Raises ValueError (the end of a sentence) when malformed or empty."""
    if isinstance(raw, list):
        if not raw:
            raise ValueError("an empty list: give at least one value")
        _check_scalars(raw)
        return Listed(key, tuple(raw))
    if not isinstance(raw, dict) or len(raw) != 1:
        raise ValueError("expected a list of values or one distribution, e.g. {uniform: [0.1, 3.0]} "
                         f"(distributions: {', '.join(DISTRIBUTIONS)})")
    (kind, bounds), = raw.items()
    if kind not in DISTRIBUTIONS:
        raise ValueError(f"unknown distribution '{kind}' (known: {', '.join(DISTRIBUTIONS)})")
    if not isinstance(bounds, list):
        raise ValueError(f"{kind} takes a list, e.g. {{{kind}: [a, b]}}")
    if kind == "choice":
        if not bounds:
            raise ValueError("choice of an empty list: give at least one value")
        _check_scalars(bounds)
        return Sampled(key, kind, tuple(bounds))
    if len(bounds) != 2 or not all(_is_number(v) for v in bounds):
        raise ValueError(f"{kind} takes two numbers, got {bounds}")
    a, b = (float(v) for v in bounds)
    if kind == "normal" and not b > 0:
        raise ValueError(f"normal takes [mean, sd] with sd > 0, got sd = {b:g}")
    if kind != "normal" and not a < b:
        raise ValueError(f"{kind} range [{a:g}, {b:g}] is empty: the low end must be below the high end")
    if kind == "log-uniform" and not a > 0:
        raise ValueError(f"log-uniform range [{a:g}, {b:g}] must be positive")
    return Sampled(key, kind, (a, b))


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _check_scalars(values: list[Any]) -> None:
    for value in values:
        if not isinstance(value, str | int | float | bool):
            raise ValueError(f"values must be numbers, text or true/false, got {value!r}")


@dataclass(frozen=True)
class Sweep:
    """The parameters of a sweep, in the order given."""

    parameters: tuple[Parameter, ...]

    @property
    def sampled(self) -> tuple[Sampled, ...]:
        return tuple(p for p in self.parameters if isinstance(p, Sampled))

    @property
    def listed(self) -> tuple[Listed, ...]:
        return tuple(p for p in self.parameters if isinstance(p, Listed))

    def grid_size(self) -> int:
        return math.prod(len(p.values) for p in self.listed)

    def count(self, samples: int | None) -> int:
        """How many members the sweep has with ``samples`` Latin hypercube samples (exact)."""
        return self.grid_size() * (samples or 1)

    def members(self, samples: int | None, seed: int) -> list[dict[str, Value]]:
        """Every member's values (key → value, keys in sweep order): each combination of the
        lists crossed with ``samples`` Latin hypercube draws of the distributions.

        Raises ValueError when ``samples`` is missing for a sweep that samples, given for one
        that does not, or below 1.
        """
        if self.sampled and samples is None:
            names = ", ".join(p.key for p in self.sampled)
            raise ValueError(f"the sweep samples {names}: give the number of samples (--members N)")
        if not self.sampled and samples is not None:
            raise ValueError(f"the sweep has lists only (a grid of {self.grid_size()} members); "
                             "--members applies to sampled parameters")
        if samples is not None and samples < 1:
            raise ValueError(f"the number of samples must be at least 1, got {samples}")
        if self.count(samples) > MAX_MEMBERS:
            raise ValueError(f"the sweep has {self.count(samples):,} members ({self.grid_size():,} "
                             f"combinations of the lists × {samples or 1:,} samples), more than the limit of "
                             f"{MAX_MEMBERS:,}; sweep fewer values or give fewer --members")
        draws = latin_hypercube(samples or 1, len(self.sampled), seed)
        sampled = [p.quantile(draws[:, i]) for i, p in enumerate(self.sampled)]
        members = []
        for combination in itertools.product(*(p.values for p in self.listed)):
            fixed = dict(zip((p.key for p in self.listed), combination, strict=True))
            for j in range(samples or 1):
                values = {**fixed, **{p.key: sampled[i][j] for i, p in enumerate(self.sampled)}}
                members.append({p.key: values[p.key] for p in self.parameters})
        return members


def latin_hypercube(samples: int, dimensions: int, seed: int) -> np.ndarray:
    """float64[samples, dimensions] in [0, 1): in each column, every stratum
    [k/samples, (k+1)/samples) holds exactly one sample (McKay et al. 1979)."""
    rng = np.random.default_rng(seed)
    strata = np.stack([rng.permutation(samples) for _ in range(dimensions)], axis=1) \
        if dimensions else np.zeros((samples, 0), dtype=np.int64)
    below_one = np.nextafter(1.0, 0.0)
    return np.minimum((strata + rng.random((samples, dimensions))) / samples, below_one)
