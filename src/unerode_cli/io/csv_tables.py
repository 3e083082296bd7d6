"""Comma-separated tables with a header row, read (observation and materials files) and
written (timelines, hypsometry, terrace reports).

Lines starting with ``#`` are comments, empty cells are missing values, and columns may come
in any order; errors name the file and the line. Written tables are UTF-8 with ``\n`` line
ends, ``None`` written as an empty cell.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from unerode_cli.errors import InputError
from unerode_cli.io.paths import atomic_path


def table_rows(path: Path, what: str, columns: tuple[str, ...], required: tuple[str, ...]):
    """(line number, {column: text}) of every data row of the ``what`` table at ``path``,
    the header checked against the known ``columns`` and the ``required`` ones.

    Raises:
        InputError: unreadable file, no header, an unknown or missing column, a row with
            another number of cells or a required value missing (naming the line).
    """
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or type(exc).__name__
        raise InputError(f"cannot read the {what} file {path}: {reason}.") from None
    numbered = [(number, line) for number, line in enumerate(text.splitlines(), start=1)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise InputError(f"the {what} file {path} has no header row.")
    reader = csv.reader(line for _, line in numbered)
    header = [name.strip() for name in next(reader)]
    unknown = [name for name in header if name not in columns]
    if unknown:
        raise InputError(
            f"{path}, line {numbered[0][0]}: unknown column '{unknown[0]}' "
            f"(the {what} columns are {', '.join(columns)})."
        )
    missing = [name for name in required if name not in header]
    if missing:
        raise InputError(
            f"{path}: the {what} file has no '{missing[0]}' column (required: {', '.join(required)})."
        )
    for (number, _), cells in zip(numbered[1:], reader, strict=False):
        if len(cells) != len(header):
            raise InputError(f"{path}, line {number}: {len(cells)} cells, the header has {len(header)}.")
        row = {name: cell.strip() for name, cell in zip(header, cells, strict=True)}
        for name in required:
            if not row[name]:
                raise InputError(f"{path}, line {number}: the required value '{name}' is missing.")
        yield number, row


def table_number(
    row: dict[str, str], name: str, path: Path, line: int, minimum: float | None = None
) -> float | None:
    """The number in column ``name`` of a row from line ``line`` of ``path`` (None when the
    cell is empty or absent), checked finite and ≥ ``minimum``; InputError naming the line."""
    text = row.get(name, "")
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{path}, line {line}: {name} must be a number, got '{text}'.") from None
    if not math.isfinite(value):
        raise InputError(f"{path}, line {line}: {name} must be a finite number, got '{text}'.")
    if minimum is not None and value < minimum:
        raise InputError(f"{path}, line {line}: {name} must be ≥ {minimum:g}, got {value:g}.")
    return value


def write_table(path: Path, columns: list[str], rows: Iterable[Mapping[str, Any]]) -> None:
    """Write ``rows`` (mappings of column → value; missing keys and ``None`` are empty cells)
    under a header of ``columns``, atomically."""
    with atomic_path(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({key: "" if row.get(key) is None else row[key] for key in columns})
