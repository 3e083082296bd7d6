"""Parsers of option values, shared by every front door (command line, pipeline spec, Python API).

A parser's ``parse(text)`` returns the value or raises ValueError with the end of a sentence
("must be > 0 years, got '-5'"). The command line calls it while parsing (a bad value is exit
code 2 before any job plans), a pipeline spec before its first step, the Python API when a job
is built. Nothing here knows a CLI framework.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

from unerode_cli.processes.parameters import ParamSpec


class OptionParser(ABC):
    """A parser of one option's value: :meth:`parse` for the pipeline, calling it for typer."""

    @abstractmethod
    def parse(self, value: Any) -> Any:
        """The value of the option's text ``value``; ValueError (end of a sentence) when bad."""


def unit_suffix(unit: str) -> str:
    """`` m/y`` after a number, nothing for a dimensionless value ("" or "1")."""
    return "" if unit in ("", "1") else f" {unit}"


def finite_number(value: Any, unit: str = "") -> float:
    """``value`` as a finite float (``unit`` names its unit in the message)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"expected a number{_in(unit)}, got '{value}'") from None
    if not math.isfinite(number):
        raise ValueError(f"must be a finite number{_in(unit)}, got '{value}'")
    return number


def _in(unit: str) -> str:
    return f" ({unit})" if unit_suffix(unit) else ""


@dataclass(frozen=True)
class Number(OptionParser):
    """A finite number in ``unit`` ("" when dimensionless), ≥ ``minimum`` (> with ``above``)
    and ≤ ``maximum`` when they are given."""

    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    above: bool = False

    def parse(self, value: Any) -> float:
        number = finite_number(value, self.unit)
        if self.minimum is not None and (number < self.minimum or self.above and number == self.minimum):
            relation = ">" if self.above else "≥"
            raise ValueError(f"must be {relation} {self.minimum:g}{unit_suffix(self.unit)}, got {value}")
        if self.maximum is not None and number > self.maximum:
            raise ValueError(f"must be ≤ {self.maximum:g}{unit_suffix(self.unit)}, got {value}")
        return number


@dataclass(frozen=True)
class Numbers(OptionParser):
    """Comma-separated finite numbers, ``count`` of them when given (else at least one);
    ``expected`` says what they are in messages, e.g. "SLOPE,INTERCEPT"."""

    expected: str
    count: int | None = None

    def parse(self, value: Any) -> tuple[float, ...]:
        parts = [part.strip() for part in str(value).split(",") if part.strip()]
        try:
            numbers = tuple(finite_number(part) for part in parts)
        except ValueError:
            numbers = ()
        if not numbers or (self.count is not None and len(numbers) != self.count):
            raise ValueError(f"expected {self.expected}, got '{value}'")
        return numbers


@dataclass(frozen=True)
class ParameterValue(OptionParser):
    """A process parameter's text: a number checked against its declaration, or, where the
    declaration allows a raster, a path (kept as text, read when the job plans)."""

    spec: ParamSpec

    def parse(self, value: Any) -> str:
        text = str(value)
        try:
            number = float(text)
        except ValueError:
            if self.spec.raster:
                return text
            raise ValueError(f"expected a number, got '{text}'") from None
        self.spec.check(number)
        return text
