"""Files of a report (``unerode-cli report``): the HTML page it writes and what it reads from a
run folder besides rasters and JSON (PNG images, CSV tables of any columns)."""

from __future__ import annotations

import csv
from pathlib import Path

from unerode_cli.errors import InputError
from unerode_cli.io.paths import atomic_path

#: The first bytes of every PNG file.
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def write_html(path: Path, text: str) -> None:
    """Write the page as UTF-8, atomically (its path cleared beforehand by check_output)."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def read_png(path: Path) -> bytes:
    """The bytes of a PNG image. InputError when unreadable or not a PNG."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read the image {path}: {exc.strerror}.") from None
    if not data.startswith(PNG_SIGNATURE):
        raise InputError(f"{path} is not a PNG image.")
    return data


def read_rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    """The header and rows (column → text) of a CSV table written by unerode-cli (timelines,
    terrace reports, ensemble tables). InputError when unreadable."""
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            return list(reader.fieldnames or []), rows
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"cannot read the table {path}: {exc}.") from None
