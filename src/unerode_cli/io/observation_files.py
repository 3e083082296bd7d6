"""Reading observation tables (CSV): dated terraces and incision rates (000 §6.3).

Both are comma-separated with a header row; lines starting with ``#`` are comments, empty
cells are missing values, and columns may come in any order.

Terraces (one row per dated level):
    age_ka (required)               age of the level (ka)
    height_above_river_m (required) height of the level above today's river (m)
    uncertainty_m                   ± uncertainty of the height (m)
    x, y                            location in the DEM's CRS (both or neither)
    chainage_m                      location as distance along the river from its downstream
                                    end (m); instead of x, y
    name                            a label
A row with no location compares with the mean height along the whole river.

Incision rates (one row per period):
    from_ka, to_ka (required)        bounds of the period (ka, either order)
    rate_mm_per_ka (required)        mean incision rate of the river (mm/ka)
    uncertainty_mm_per_ka            ± uncertainty (mm/ka)
    name                             a label
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from unerode_cli.analysis.incision import IncisionPeriod
from unerode_cli.errors import InputError
from unerode_cli.io.csv_tables import table_number, table_rows

TERRACE_COLUMNS = ("age_ka", "height_above_river_m", "uncertainty_m", "x", "y", "chainage_m", "name")
TERRACE_REQUIRED = ("age_ka", "height_above_river_m")
INCISION_COLUMNS = ("from_ka", "to_ka", "rate_mm_per_ka", "uncertainty_mm_per_ka", "name")
INCISION_REQUIRED = ("from_ka", "to_ka", "rate_mm_per_ka")


@dataclass(frozen=True)
class TerraceRow:
    """A terrace row as read; its location is resolved against the river later.

    ``line`` is the line number in the file (1 = first line)."""

    line: int
    age_ka: float
    height_m: float
    uncertainty_m: float | None
    name: str
    x: float | None
    y: float | None
    chainage_m: float | None


def read_terraces(path: Path) -> list[TerraceRow]:
    """The terrace observations in ``path`` (see the module docstring for the columns).

    Raises:
        InputError: naming the line of a row with a missing or malformed value.
    """
    terraces = []
    for line, row in table_rows(path, "observations", TERRACE_COLUMNS, TERRACE_REQUIRED):
        x, y = table_number(row, "x", path, line), table_number(row, "y", path, line)
        chainage = table_number(row, "chainage_m", path, line, minimum=0.0)
        if (x is None) != (y is None):
            raise InputError(f"{path}, line {line}: give both x and y, or neither.")
        if x is not None and chainage is not None:
            raise InputError(f"{path}, line {line}: give the location as x, y or as chainage_m, not both.")
        terraces.append(TerraceRow(
            line=line,
            age_ka=table_number(row, "age_ka", path, line, minimum=0.0),
            height_m=table_number(row, "height_above_river_m", path, line),
            uncertainty_m=table_number(row, "uncertainty_m", path, line, minimum=0.0),
            name=row.get("name", ""),
            x=x, y=y, chainage_m=chainage,
        ))
    if not terraces:
        raise InputError(f"the observations file {path} has no data row.")
    return terraces


def read_incision(path: Path) -> list[IncisionPeriod]:
    """The observed incision rates in ``path`` (see the module docstring for the columns).

    Raises:
        InputError: naming the line of a row with a missing or malformed value.
    """
    periods = []
    for line, row in table_rows(path, "incision", INCISION_COLUMNS, INCISION_REQUIRED):
        start = table_number(row, "from_ka", path, line, minimum=0.0)
        end = table_number(row, "to_ka", path, line, minimum=0.0)
        if start == end:
            raise InputError(f"{path}, line {line}: from_ka and to_ka are the same age.")
        periods.append(IncisionPeriod(
            line=line,
            old_ka=max(start, end),
            young_ka=min(start, end),
            rate_mm_per_ka=table_number(row, "rate_mm_per_ka", path, line),
            uncertainty_mm_per_ka=table_number(row, "uncertainty_mm_per_ka", path, line, minimum=0.0),
            name=row.get("name", ""),
        ))
    if not periods:
        raise InputError(f"the incision file {path} has no data row.")
    return periods
