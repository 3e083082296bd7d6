"""Reading chronology tables (δ18O stacks, sea-level curves) from files: the only code that
opens them; parsing is ``unerode_cli.climate.chronology.parse_table`` (pure). Also the CSV
tables of one value by age that a run is given (e.g. the uplift rate through time).

Ages in the files are in ka (thousands of years before present), values in the table's unit.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from unerode_cli.climate.chronology import Series, parse_table
from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import table_number, table_rows


def read_series(path: Path, kind: str, column: str | None = None,
                on_note: Callable[[str], None] | None = None) -> Series:
    """The chronology in ``path`` (see ``parse_table`` for the layouts, kinds and ``column``).

    The text is decoded as UTF-8, or as Latin-1 when it is not valid UTF-8 (NOAA template
    files hold Latin-1 bytes in their headers). Rows left out or sorted by ``parse_table`` are
    told to ``on_note``, one ``note: ...`` each.

    Raises:
        InputError: the file is missing or unreadable, or its table is malformed (one sentence).
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InputError(f"cannot read the chronology file {path}: {reason}.") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    try:
        series = parse_table(text, kind, str(path), column)
    except ValueError as exc:
        raise InputError(f"{exc}.") from None
    if on_note is not None:
        for change in series.changes:
            on_note(f"note: {change}.")
    return series


def read_age_table(path: Path, what: str, columns: tuple[str, ...]) -> Series:
    """The CSV table of ``age_ka`` and exactly one of the value ``columns`` at ``path`` (header
    row, ``#`` comments, rows in any order, each age once) as a series sorted by age, named
    after its value column; ``what`` names the table in messages (e.g. "uplift").

    Raises:
        InputError: unreadable file, an unknown column, not exactly one value column, a missing
            or malformed value or an age given twice (naming its line), fewer than two rows.
    """
    column = ""
    lines: dict[float, int] = {}
    values: dict[float, float] = {}
    for line, row in table_rows(path, what, ("age_ka", *columns), ("age_ka",)):
        column = column or _value_column(row, columns, path, what)
        age = table_number(row, "age_ka", path, line)
        value = table_number(row, column, path, line)
        if value is None:
            raise InputError(f"{path}, line {line}: the required value '{column}' is missing.")
        if age in lines:
            raise InputError(f"{path}, line {line}: age {age:g} ka is given twice (first on line "
                             f"{lines[age]}).")
        lines[age], values[age] = line, value
    if len(values) < 2:
        raise InputError(f"the {what} table {path} needs at least two rows of age_ka and a value.")
    ages = np.array(sorted(values))
    return Series(ages, np.array([values[a] for a in ages]), name=column)


def _value_column(row: dict[str, str], columns: tuple[str, ...], path: Path, what: str) -> str:
    """The one value column of a table whose rows have the keys of ``row``."""
    present = [name for name in columns if name in row]
    if len(present) != 1:
        raise InputError(f"the {what} table {path} needs exactly one value column besides age_ka: "
                         f"{' or '.join(columns)}.")
    return present[0]
