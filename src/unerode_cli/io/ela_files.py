"""Reading the chronology an ELA follows (``unerode_cli.climate.ela``): a δ18O stack, a
sea-level curve or a temperature curve, by the ELA proxy kind; and ELA time tables (the ELA
through a run, ``glacier.coupled.ElaTable``).

δ18O and sea-level tables are read as ``read_series`` reads them. A temperature table is read
as a generic (age, value) table; its default column is the second of a two-column table, or
``Tsurf`` of Bintanja & van de Wal 2008 (``sealevel/bintanja_vandewal2008_3Myr.csv``: surface
air temperature anomaly relative to present, K, negative = colder; −15.9 K at 19.6 ka).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import numpy as np

from unerode_cli.climate.chronology import Series
from unerode_cli.climate.ela import ELA_KINDS
from unerode_cli.errors import InputError
from unerode_cli.glacier.coupled import ElaTable
from unerode_cli.io.chronology_files import read_series
from unerode_cli.io.csv_tables import table_number, table_rows

#: The temperature column of Bintanja & van de Wal 2008 (K, anomaly relative to present).
BINTANJA_TEMPERATURE_COLUMN = "Tsurf"


def read_ela_proxy(path: Path, kind: str, column: str | None = None,
                   on_note: Callable[[str], None] | None = None) -> Series:
    """The proxy of ELA kind ``kind`` (one of ``ELA_KINDS``) in ``path``, by age (ka).

    ``"d18o"`` and ``"sea-level"``: ``read_series(path, kind, column, on_note)``.
    ``"temperature"``: the column ``column`` (a header name or a 1-based number as text); when
    None, ``Tsurf`` if the header has it, else the second column of a two-column table. Its
    unit is ``"K"`` (temperatures in °C read the same: only differences are used).

    Raises:
        InputError: an unknown kind, an unreadable file, a malformed table, or a table of
            several columns where none was chosen (one sentence).
    """
    if kind not in ELA_KINDS:
        raise InputError(f"unknown ELA proxy kind {kind!r}; use one of {', '.join(ELA_KINDS)}.")
    if kind != "temperature":
        return read_series(path, kind, column, on_note)
    if column is None:
        try:
            series = read_series(path, "generic", BINTANJA_TEMPERATURE_COLUMN, on_note)
        except InputError:
            series = read_series(path, "generic", None, on_note)
    else:
        series = read_series(path, "generic", column, on_note)
    return dataclasses.replace(series, unit="K")


#: Columns of an ELA time table: the time (years since the start of the run) and the ELA (m).
ELA_TABLE_COLUMNS = ("time", "ela")


def read_ela_table(path: Path) -> ElaTable:
    """The ELA table at ``path``: a CSV with the columns ``time`` (years since the start of the
    run, strictly increasing) and ``ela`` (m), interpolated linearly and held beyond its ends.

    Raises:
        InputError: an unreadable file, a malformed table, times that do not increase, or no
            row (one sentence naming the file, and the line where there is one).
    """
    times: list[float] = []
    values: list[float] = []
    for line, row in table_rows(path, "ELA", ELA_TABLE_COLUMNS, ELA_TABLE_COLUMNS):
        t, e = table_number(row, "time", path, line), table_number(row, "ela", path, line)
        if times and t <= times[-1]:
            raise InputError(f"{path}, line {line}: the times of an ELA table must increase.")
        times.append(t)
        values.append(e)
    if not times:
        raise InputError(f"the ELA table {path} has no row.")
    return ElaTable(np.array(times), np.array(values))
