"""Reading chronology tables (δ18O stacks, sea-level curves) from files: the only code that
opens them; parsing is ``unerode_cli.climate.chronology.parse_table`` (pure).

Ages in the files are in ka (thousands of years before present), values in the table's unit.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from unerode_cli.climate.chronology import Series, parse_table
from unerode_cli.errors import InputError


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
