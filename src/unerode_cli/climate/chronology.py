"""Chronologies: tables of (age, value) read from text, and linear interpolation in them.

A chronology is what drives a full backward simulation from climate (000 §5, DESIGN §7): an
LR04-style benthic δ18O stack, a sea-level curve or any other (age, value) curve.

Units: these table functions work in **ka** (thousands of years before present, 0 = present,
larger = older) by nature, because that is how every published chronology is written; ages
are in ka only here, at the edge. The rest of the project counts time in years (SI inside):
convert with :data:`YEARS_PER_KA`. Values keep the table's unit (‰ for δ18O, metres relative
to present sea level for sea level).

This module is pure: it parses text it is given (``parse_table``) and never opens a file; the
pipeline layer reads files (``unerode_cli.io.chronology_files``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Years in one ka (1 ka = 1000 years): ages in ka × YEARS_PER_KA = ages in years.
YEARS_PER_KA = 1000.0

#: Table kinds understood by :func:`parse_table`.
KINDS: tuple[str, ...] = ("d18o", "sea-level", "generic")

#: Default value column of a sea-level table with several columns, by known file layout
#: (recognised by the column names of its header line): Spratt & Lisiecki 2016 (NOAA file,
#: long principal component over 0–798 ka) and Bintanja & van de Wal 2008 (PleistoDist CSV,
#: sea level with negative = lower than today, 0 at 0 ka).
SEA_LEVEL_COLUMNS: tuple[str, ...] = ("SeaLev_longPC1", "Sealevel_Corrected")

_UNITS = {"d18o": "‰", "sea-level": "m", "generic": ""}
_NAMES = {"d18o": "benthic δ18O", "sea-level": "sea level", "generic": "value"}
# relative slack on the range check, so that ages computed from years (e.g. 798.0000000001 ka)
# are not refused for a rounding error
_RANGE_SLACK = 1e-9


@dataclass(frozen=True)
class Series:
    """A chronology: values at ages, linearly interpolated between samples.

    Attributes:
        age_ka: sample ages in ka (thousands of years before present), float64, strictly
            ascending, at least two.
        value: the values at those ages (float64, finite), in ``unit``.
        name: what the values are (e.g. the column name ``"SeaLev_longPC1"``).
        unit: unit of ``value``: ``"‰"`` for δ18O, ``"m"`` for sea level relative to present
            (negative = lower than today), ``""`` when unknown.
        note: how the values were derived from the source table (column, shifts), for
            provenance; empty when nothing was changed.
        changes: what :func:`parse_table` changed in the rows as written, one sentence each
            (rows dropped, rows sorted), to tell the user; empty when nothing was.

    The valid range of ages is ``[start_ka, end_ka]``; :meth:`at` refuses ages outside it
    (no extrapolation).
    """

    age_ka: np.ndarray
    value: np.ndarray
    name: str = "value"
    unit: str = ""
    note: str = ""
    changes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        age = np.array(self.age_ka, dtype=np.float64).reshape(-1)
        value = np.array(self.value, dtype=np.float64).reshape(-1)
        if age.shape != value.shape:
            raise ValueError(
                f"the chronology {self.name!r} has {age.size} ages but {value.size} values"
            )
        if age.size < 2:
            raise ValueError(f"the chronology {self.name!r} needs at least two samples, got {age.size}")
        if not (np.all(np.isfinite(age)) and np.all(np.isfinite(value))):
            raise ValueError(f"the chronology {self.name!r} has non-finite ages or values")
        if np.any(np.diff(age) <= 0.0):
            raise ValueError(f"the ages of the chronology {self.name!r} must be strictly ascending")
        age.flags.writeable = False
        value.flags.writeable = False
        object.__setattr__(self, "age_ka", age)
        object.__setattr__(self, "value", value)

    @property
    def start_ka(self) -> float:
        """Youngest age of the table (ka); the first age :meth:`at` accepts."""
        return float(self.age_ka[0])

    @property
    def end_ka(self) -> float:
        """Oldest age of the table (ka); the last age :meth:`at` accepts."""
        return float(self.age_ka[-1])

    def __len__(self) -> int:
        return int(self.age_ka.size)

    def covers(self, age_ka: float | np.ndarray) -> bool:
        """Whether every age (ka) is inside ``[start_ka, end_ka]`` (NaN is not)."""
        ages = np.asarray(age_ka, dtype=np.float64)
        slack = _RANGE_SLACK * max(1.0, self.end_ka - self.start_ka)
        return bool(np.all((ages >= self.start_ka - slack) & (ages <= self.end_ka + slack)))

    def at(self, age_ka: float | np.ndarray) -> float | np.ndarray:
        """Value at ``age_ka`` (ka; a scalar or an array of any shape), linearly interpolated
        between the two neighbouring samples, exact at a sample.

        Returns a float for a scalar age, else a float64 array of the same shape.

        Raises:
            ValueError: an age is NaN or outside ``[start_ka, end_ka]`` (one sentence).
        """
        ages = np.asarray(age_ka, dtype=np.float64)
        if not self.covers(ages):
            bad = ages[~((ages >= self.start_ka) & (ages <= self.end_ka))].reshape(-1)
            worst = float(bad[0]) if bad.size else math.nan
            if math.isnan(worst):
                raise ValueError(f"an age asked of the chronology {self.name!r} is NaN, not a number of ka")
            raise ValueError(
                f"age {worst:g} ka is outside the chronology {self.name!r}, which covers "
                f"{self.start_ka:g}–{self.end_ka:g} ka"
            )
        out = np.interp(ages, self.age_ka, self.value)
        return float(out) if np.ndim(out) == 0 else out

    def mean(self, start_ka: float, end_ka: float) -> float:
        """Mean value between two different ages (ka, either order): the integral of the
        piecewise-linear curve over the span divided by the span, exact (trapezoids between the
        samples that fall inside). Without a sample strictly inside, it is the value at the
        middle age.

        Raises:
            ValueError: the ages are equal, or one is outside ``[start_ka, end_ka]`` of the
                table (one sentence).
        """
        lo, hi = sorted((float(start_ka), float(end_ka)))
        if not hi > lo:
            raise ValueError(f"the mean of the chronology {self.name!r} needs two different ages")
        inside = self.age_ka[(self.age_ka > lo) & (self.age_ka < hi)]
        ages = np.concatenate(([lo], inside, [hi]))
        values = np.asarray(self.at(ages))
        return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(ages)) / (hi - lo))


def parse_table(text: str, kind: str, source: str, column: str | None = None) -> Series:
    """Parse a chronology table (age in ka in the first column, then values) from ``text``.

    Accepted layout:
        - comment lines starting with ``#`` and blank lines anywhere; text lines (any line whose
          first field is not a number) before the first data row — the last such line with as
          many fields as the data rows is taken as the column names (NOAA templates, CSV
          headers);
        - fields separated by commas (CSV, when the line holds a comma) or by TABs/spaces;
          a trailing separator is ignored; ``NaN`` (or an empty CSV field) is a missing value;
        - line endings LF, CRLF or CR, mixed.

    Rows whose age or chosen value is missing are dropped; rows are sorted by age; two rows for
    the same age are refused. What was dropped or sorted is said in the ``changes`` of the
    result.

    Kinds and value column (``column``: a column name from the header line, or a 1-based
    column number written as text, e.g. ``"3"``):
        - ``"d18o"``: LR04-style benthic δ18O stack, columns age (ka), δ18O (‰), optional
          standard error (‰); default value column: the second. Unit ``"‰"``.
        - ``"sea-level"``: sea level in metres relative to present (negative = lower than
          today). Default column: the second when the table has two columns, else the first
          header name found in :data:`SEA_LEVEL_COLUMNS` (``SeaLev_longPC1`` of Spratt &
          Lisiecki 2016, ``Sealevel_Corrected`` of Bintanja & van de Wal 2008). **Anchoring of
          "present":** when the table covers 0 ka, the whole curve is shifted so that its value
          at 0 ka is exactly 0 m, because the DEM being (un)eroded is today's terrain and its
          sea level is 0 m. (Spratt 2016 is published with 0 m at 5 ka and +8.96 m at 0 ka; the
          shift lowers it by 8.96 m. Bintanja's ``Sealevel_Corrected`` is already 0 at 0 ka.)
          A table that does not cover 0 ka is left as it is. The shift is written in ``note``.
        - ``"generic"``: age (ka), value; default column: the second when the table has two
          columns, else ``column`` is required. Unit ``""``.

    Args:
        text: the table's text (already decoded).
        kind: one of :data:`KINDS`.
        source: how to name the table in error messages (e.g. its path).
        column: the value column, see above; None for the default.

    Raises:
        ValueError: one sentence naming ``source`` (and the line, where there is one).
    """
    if kind not in KINDS:
        raise ValueError(f"unknown chronology kind {kind!r} for {source}; use one of {', '.join(KINDS)}")
    names, rows, lines = _read_rows(text, source)
    width = rows.shape[1]
    index = _value_column(kind, source, column, names, width)
    age, value = rows[:, 0], rows[:, index]
    keep = np.isfinite(age) & np.isfinite(value)
    changes = _dropped(source, lines[~keep])
    age, value, lines = age[keep], value[keep], lines[keep]
    if age.size < 2:
        raise ValueError(f"{source} has fewer than two rows with both an age and a value")
    backward = np.flatnonzero(np.diff(age) < 0.0)
    if backward.size:
        changes += (f"the rows of {source} are not in age order (line {lines[backward[0] + 1]} is "
                    "younger than the row before it); they were sorted by age",)
    order = np.argsort(age, kind="stable")
    age, value, lines = age[order], value[order], lines[order]
    same = np.flatnonzero(np.diff(age) == 0.0)
    if same.size:
        k = int(same[0])
        raise ValueError(
            f"{source} has two rows for age {age[k]:g} ka (lines {lines[k]} and {lines[k + 1]})"
        )
    name = names[index] if names is not None else _NAMES[kind]
    note = f"column {index + 1} ({name}) of {source}"
    if kind == "sea-level" and age[0] <= 0.0 <= age[-1]:
        offset = float(np.interp(0.0, age, value))
        if offset != 0.0:
            value = value - offset
            note += f", shifted by {-offset:+.4g} m so that 0 ka = 0 m"
    return Series(age, value, name=name, unit=_UNITS[kind], note=note, changes=changes)


def _dropped(source: str, lines: np.ndarray) -> tuple[str, ...]:
    """The sentence saying which rows (their 1-based ``lines``) were dropped, if any."""
    if not lines.size:
        return ()
    return (f"{lines.size} row(s) of {source} without an age or a value were left out (first on "
            f"line {lines[0]})",)


def _read_rows(text: str, source: str) -> tuple[list[str] | None, np.ndarray, np.ndarray]:
    """(column names or None, float rows [n, width], 1-based line number of each row)."""
    header: list[list[str]] = []
    rows: list[list[float]] = []
    lines: list[int] = []
    width = 0
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = _split(line)
        numbers = _numbers(fields)
        if numbers is None:
            if rows:
                raise ValueError(
                    f"{source} line {number} is not a row of numbers: {_clip(line)!r}"
                )
            header.append(fields)
            continue
        if not rows:
            width = len(numbers)
            if width < 2:
                raise ValueError(
                    f"{source} line {number} has one column; a chronology needs an age and a value"
                )
        elif len(numbers) != width:
            raise ValueError(
                f"{source} line {number} has {len(numbers)} fields, the first data row has {width}"
            )
        rows.append(numbers)
        lines.append(number)
    if not rows:
        raise ValueError(f"{source} has no data rows (lines of numbers: age in ka, then values)")
    names = next((fields for fields in reversed(header) if len(fields) == width), None)
    return names, np.array(rows, dtype=np.float64), np.array(lines, dtype=np.int64)


def _split(line: str) -> list[str]:
    """Fields of a stripped line: comma separated when it holds a comma, else TABs/spaces."""
    if "," in line:
        fields = [field.strip() for field in line.split(",")]
        if len(fields) > 1 and fields[-1] == "":
            fields.pop()
        return fields
    return line.split()


def _numbers(fields: list[str]) -> list[float] | None:
    """The fields as floats (empty → NaN), or None when the line is text (a header)."""
    out: list[float] = []
    for i, field in enumerate(fields):
        if field == "" and i > 0:
            out.append(math.nan)
            continue
        try:
            out.append(float(field))
        except ValueError:
            return None
    return out


def _value_column(kind: str, source: str, column: str | None, names: list[str] | None,
                  width: int) -> int:
    """0-based index of the value column (see :func:`parse_table`)."""
    if column is not None:
        text = str(column).strip()
        if names is not None and text in names:
            index = names.index(text)
        elif text.isdigit():
            index = int(text) - 1
            if not 1 <= index + 1 <= width:
                raise ValueError(f"{source} has {width} columns, so column {text} does not exist")
        else:
            known = f" (columns: {', '.join(names)})" if names is not None else " (it has no header line)"
            raise ValueError(f"{source} has no column named {text!r}{known}")
        if index == 0:
            raise ValueError(f"column 1 of {source} holds the ages; choose a value column")
        return index
    if kind == "d18o" or width == 2:
        return 1
    if kind == "sea-level" and names is not None:
        for name in SEA_LEVEL_COLUMNS:
            if name in names:
                return names.index(name)
    raise ValueError(
        f"{source} has {width} columns; say which one holds the {_NAMES[kind]} (column name or number)"
    )


def _clip(line: str, size: int = 60) -> str:
    return line if len(line) <= size else line[: size - 1] + "…"
