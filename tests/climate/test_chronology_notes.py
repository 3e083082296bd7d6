"""Rows a chronology table loses or has reordered when it is read are said, once, as notes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from tests.conftest import run_cli, write_geotiff

from unerode_cli.climate.chronology import Series, parse_table
from unerode_cli.io.chronology_files import read_series

UNSORTED = "# age_ka d18o\n0 3.2\n2 3.4\n1 NaN\n1.5 3.3\n3 3.5\n"


def test_parse_table_says_what_it_dropped_and_sorted() -> None:
    series = parse_table(UNSORTED, "d18o", "t.txt")
    np.testing.assert_array_equal(series.age_ka, [0.0, 1.5, 2.0, 3.0])
    assert series.changes == (
        "1 row(s) of t.txt without an age or a value were left out (first on line 4)",
        "the rows of t.txt are not in age order (line 5 is younger than the row before it); "
        "they were sorted by age",
    )


def test_a_clean_table_changes_nothing(lr04: Series, spratt: Series) -> None:
    assert parse_table("0 3.2\n1 3.3\n", "d18o", "t.txt").changes == ()
    assert lr04.changes == () and spratt.changes == ()


def test_read_series_passes_each_change_on_as_a_note(tmp_path: Path) -> None:
    path = tmp_path / "t.txt"
    path.write_text(UNSORTED)
    heard: list[str] = []
    read_series(path, "d18o", on_note=heard.append)
    assert [text.split(" of ")[0] for text in heard] == ["note: 1 row(s)", "note: the rows"]
    assert all(text.endswith(".") for text in heard)


def test_climate_run_says_each_note_once_and_quiet_silences_them(tmp_path: Path) -> None:
    rows, cols = np.indices((12, 12))
    dem = write_geotiff(tmp_path / "dem.tif", (5.0 + 0.6 * (11 - rows) + 0.1 * cols).astype(np.float32))
    table = tmp_path / "d18o.txt"
    table.write_text("".join(f"{age} {3.2 + 0.02 * age:.3f}\n" for age in reversed(range(41))) + "7 nan\n")
    args = ["climate-run", dem, tmp_path / "past.tif", "--chronology", table, "--to", 2, "--process",
            "fluvial", "--snapshots", "1", "--overwrite"]
    result = run_cli(*args)
    assert result.returncode == 0, result.stderr
    said = [line for line in result.stderr.splitlines() if line.startswith("note: ")]
    assert said == [f"note: 1 row(s) of {table} without an age or a value were left out (first on line 42).",
                    f"note: the rows of {table} are not in age order (line 2 is younger than the row "
                    "before it); they were sorted by age."]
    quiet = run_cli(*args, "-q")
    assert quiet.returncode == 0, quiet.stderr
    assert "note:" not in quiet.stderr
