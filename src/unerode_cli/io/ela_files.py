"""Reading the chronology an ELA follows (``unerode_cli.climate.ela``): a δ18O stack, a
sea-level curve or a temperature curve, by the ELA proxy kind.

δ18O and sea-level tables are read as ``read_series`` reads them. A temperature table is read
as a generic (age, value) table; its default column is the second of a two-column table, or
``Tsurf`` of Bintanja & van de Wal 2008 (``sealevel/bintanja_vandewal2008_3Myr.csv``: surface
air temperature anomaly relative to present, K, negative = colder; −15.9 K at 19.6 ka).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from unerode_cli.climate.chronology import Series
from unerode_cli.climate.ela import ELA_KINDS
from unerode_cli.errors import InputError
from unerode_cli.io.chronology_files import read_series

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
