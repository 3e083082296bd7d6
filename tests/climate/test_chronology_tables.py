"""Chronology tables (DESIGN §7): the real LR04 δ18O stack and sea-level curves load with the
row counts and ranges their PROVENANCE.md files state; interpolation is exact at samples and
linear between; malformed tables are refused in one sentence naming the source and line."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.climate.conftest import BINTANJA, LR04, SPRATT

from unerode_cli.climate.chronology import YEARS_PER_KA, Series, parse_table
from unerode_cli.errors import InputError
from unerode_cli.io.chronology_files import read_series


def one_sentence(message: str) -> bool:
    """A single sentence: no line break, no second sentence after a full stop."""
    return "\n" not in message and not re.search(r"[.!?]\s+[A-Z]", message) and len(message) < 300


# --- the real files ---------------------------------------------------------------------------

def test_lr04_stack_loads_2115_rows_0_to_5320_ka(lr04):
    assert len(lr04) == 2115
    assert (lr04.start_ka, lr04.end_ka) == (0.0, 5320.0)
    assert lr04.unit == "‰"
    # first and last rows as PROVENANCE.md quotes them, range of δ18O 2.65–5.08 ‰
    assert lr04.at(0.0) == pytest.approx(3.23)
    assert lr04.at(5320.0) == pytest.approx(2.91)
    assert lr04.value.min() == pytest.approx(2.65) and lr04.value.max() == pytest.approx(5.08)


def test_spratt_sea_level_loads_799_rows_anchored_at_present(spratt):
    assert len(spratt) == 799
    assert (spratt.start_ka, spratt.end_ka) == (0.0, 798.0)
    assert spratt.name == "SeaLev_longPC1" and spratt.unit == "m"
    # published with 0 m at 5 ka and +8.96 m at 0 ka; anchored here so that 0 ka = 0 m
    assert spratt.at(0.0) == 0.0
    assert spratt.at(5.0) == pytest.approx(-8.96, abs=1e-9)
    assert "shifted" in spratt.note
    # long PC1 range −130.0 … +19.0 m before the shift
    assert spratt.value.min() == pytest.approx(-130.0 - 8.96, abs=0.05)
    assert spratt.value.max() == pytest.approx(19.0 - 8.96, abs=0.05)


def test_spratt_short_column_stops_at_430_ka():
    short = read_series(SPRATT, "sea-level", column="SeaLev_shortPC1")
    assert len(short) == 431 and short.end_ka == 430.0  # NaN rows beyond 430 ka dropped
    assert short.at(5.0) == pytest.approx(-8.49, abs=1e-9)  # its own 0 ka value is +8.49 m


def test_bintanja_sea_level_loads_30001_rows_0_to_3000_ka(bintanja):
    assert len(bintanja) == 30001
    assert (bintanja.start_ka, bintanja.end_ka) == (0.0, 3000.0)
    assert bintanja.name == "Sealevel_Corrected"
    assert bintanja.at(0.0) == 0.0 and "shifted" not in bintanja.note
    assert bintanja.value.min() == pytest.approx(-126.1, abs=0.05)
    assert bintanja.value.max() == pytest.approx(2.9, abs=0.05)


def test_other_bintanja_column_by_name_or_number():
    by_name = read_series(BINTANJA, "generic", column="Tsurf")
    by_number = read_series(BINTANJA, "generic", column="5")
    np.testing.assert_array_equal(by_name.value, by_number.value)
    assert by_name.at(0.1001) == pytest.approx(-0.0614)


# --- interpolation ----------------------------------------------------------------------------

def test_interpolation_exact_at_samples_and_linear_between(lr04):
    np.testing.assert_array_equal(lr04.at(lr04.age_ka), lr04.value)
    # LR04: 3.23 ‰ at 0 ka and 1 ka, 3.52 at 10 ka, 3.60 at 11 ka
    assert lr04.at(10.25) == pytest.approx(3.52 + 0.25 * (3.60 - 3.52), abs=1e-12)
    assert isinstance(lr04.at(10.25), float)
    grid = np.array([[10.0, 10.5], [11.0, 600.5]])
    out = lr04.at(grid)
    assert out.shape == (2, 2)
    left, right = lr04.at(600.0), lr04.at(602.0)  # 2 kyr sampling beyond 600 ka
    assert out[1, 1] == pytest.approx(left + 0.25 * (right - left), abs=1e-12)


def test_outside_the_range_is_refused_in_one_sentence(spratt):
    for age in (-0.5, 798.5, 2000.0):
        with pytest.raises(ValueError, match=r"outside the chronology .* 0–798 ka") as info:
            spratt.at(age)
        assert one_sentence(str(info.value))
    with pytest.raises(ValueError, match="outside"):
        spratt.at(np.array([10.0, 900.0]))
    with pytest.raises(ValueError, match="NaN"):
        spratt.at(math.nan)
    # a rounding error from a conversion of years is not refused
    assert spratt.at(798_000.0000001 / YEARS_PER_KA) == pytest.approx(spratt.value[-1])


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(st.floats(0.01, 50.0), min_size=1, max_size=30),
    start=st.floats(-10.0, 100.0),
    values=st.lists(st.floats(-200.0, 200.0), min_size=31, max_size=31),
    style=st.sampled_from(["csv", "tab", "spaces"]),
    where=st.floats(0.0, 1.0),
    shuffle_seed=st.integers(0, 2**16),
)
def test_parse_then_interpolate_matches_np_interp(steps, start, values, style, where, shuffle_seed):
    """Whatever the separator, order or comment lines, a table written from (age, value) pairs
    parses back to the same samples and interpolates like np.interp."""
    age = start + np.concatenate([[0.0], np.cumsum(steps)])
    value = np.array(values[: age.size])
    if np.any(np.diff(age) <= 0):
        return
    sep = {"csv": ",", "tab": "\t", "spaces": "   "}[style]
    order = np.random.default_rng(shuffle_seed).permutation(age.size)
    lines = ["# a comment", f"age{sep}value{sep}"]
    lines += [f"{float(age[i])!r}{sep}{float(value[i])!r}{sep if i % 2 else ''}" for i in order]
    lines.insert(3, "")
    series = parse_table("\r\n".join(lines), "generic", "prop.txt")
    np.testing.assert_array_equal(series.age_ka, age)
    np.testing.assert_array_equal(series.value, value)
    asked = age[0] + where * (age[-1] - age[0])
    assert series.at(asked) == pytest.approx(float(np.interp(asked, age, value)), abs=1e-9)


# --- layouts ----------------------------------------------------------------------------------

def test_headers_trailing_separators_nan_rows_and_order():
    text = (
        "Some title line\n# comment\nage\tsea\terr\t\n"
        "2\t-10\t1\t\n0\t0\t1\t\n1\tNaN\t1\t\n3\t-30\tNaN\t\n"
    )
    series = parse_table(text, "sea-level", "t.txt", column="sea")
    np.testing.assert_array_equal(series.age_ka, [0.0, 2.0, 3.0])  # NaN value row dropped, sorted
    np.testing.assert_array_equal(series.value, [0.0, -10.0, -30.0])
    two = parse_table("a,b\n0,1\n1,2,\n", "generic", "t.csv")
    np.testing.assert_array_equal(two.value, [1.0, 2.0])


def test_sea_level_not_covering_present_is_not_shifted():
    series = parse_table("5 -3\n6 -4\n", "sea-level", "s.txt")
    assert series.at(5.0) == -3.0 and series.note.endswith("s.txt")


@pytest.mark.parametrize(
    ("text", "kind", "column", "pattern"),
    [
        ("", "d18o", None, r"^e\.txt has no data rows"),
        ("# only\n# comments\n", "d18o", None, r"^e\.txt has no data rows"),
        ("0 1\n1 2\n2 x\n", "d18o", None, r"^e\.txt line 3 is not a row of numbers"),
        ("0 1 2\n1 2\n", "d18o", None, r"^e\.txt line 2 has 2 fields, the first data row has 3"),
        ("0 1\n1 2\n0 3\n", "d18o", None, r"^e\.txt has two rows for age 0 ka \(lines 1 and 3\)"),
        ("0\n1\n", "generic", None, r"^e\.txt line 1 has one column"),
        ("0 1\n", "generic", None, r"^e\.txt has fewer than two rows"),
        ("0 NaN\n1 NaN\n", "generic", None, r"^e\.txt has fewer than two rows"),
        ("a b c\n0 1 2\n1 2 3\n", "generic", None, r"^e\.txt has 3 columns; say which one"),
        ("a b c\n0 1 2\n1 2 3\n", "sea-level", None, r"^e\.txt has 3 columns; say which one holds the sea"),
        ("a b c\n0 1 2\n1 2 3\n", "generic", "d", r"^e\.txt has no column named 'd' \(columns: a, b, c\)"),
        ("0 1 2\n1 2 3\n", "generic", "x", r"^e\.txt has no column named 'x' \(it has no header"),
        ("0 1 2\n1 2 3\n", "generic", "4", r"^e\.txt has 3 columns, so column 4 does not exist"),
        ("a b\n0 1\n1 2\n", "generic", "a", r"^column 1 of e\.txt holds the ages"),
        ("0 1\n1 2\n", "temperature", None, r"^unknown chronology kind 'temperature' for e\.txt"),
    ],
)
def test_malformed_tables_are_refused_in_one_sentence(text, kind, column, pattern):
    with pytest.raises(ValueError, match=pattern) as info:
        parse_table(text, kind, "e.txt", column)
    assert one_sentence(str(info.value))


def test_series_checks_its_own_arrays():
    with pytest.raises(ValueError, match="strictly ascending"):
        Series(np.array([0.0, 2.0, 1.0]), np.zeros(3))
    with pytest.raises(ValueError, match="at least two samples"):
        Series(np.array([0.0]), np.zeros(1))
    with pytest.raises(ValueError, match="3 ages but 2 values"):
        Series(np.arange(3.0), np.zeros(2))
    series = Series(np.arange(3.0), np.zeros(3))
    with pytest.raises(ValueError):
        series.age_ka[0] = 5.0  # read-only: a Series never changes


# --- the file reader (pipeline layer) ---------------------------------------------------------

def test_reader_refuses_missing_and_malformed_files_with_input_errors(tmp_path):
    with pytest.raises(InputError, match=r"^cannot read the chronology file .*nope\.txt: ") as info:
        read_series(tmp_path / "nope.txt", "d18o")
    assert one_sentence(str(info.value))
    with pytest.raises(InputError, match="cannot read the chronology file"):
        read_series(tmp_path, "d18o")  # a folder
    bad = tmp_path / "bad.txt"
    bad.write_text("0 1\n1 two\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"bad\.txt line 2 is not a row of numbers.*\.$") as info:
        read_series(bad, "d18o")
    assert one_sentence(str(info.value))


def test_reader_falls_back_to_latin1(tmp_path):
    path = tmp_path / "latin.txt"
    path.write_bytes("# d\xe9j\xe0 vu \u00b0C\n0\t1\n1\t2\n".encode("latin-1"))
    assert len(read_series(path, "generic")) == 2
    assert read_series(LR04, "d18o").at(1.0) == pytest.approx(3.23)


def test_mean_over_a_span_is_the_exact_integral_of_the_linear_curve():
    series = Series([0.0, 1.0, 3.0], [0.0, 2.0, 0.0])
    assert series.mean(0.0, 3.0) == pytest.approx(1.0, abs=1e-15)  # triangle: area 3 over 3 ka
    assert series.mean(2.0, 0.5) == pytest.approx((0.5 * (1.0 + 2.0) / 2 + (2.0 + 1.0) / 2) / 1.5, abs=1e-15)
    assert series.mean(1.5, 2.5) == pytest.approx(series.at(2.0), abs=1e-15)  # no sample inside
    with pytest.raises(ValueError, match="two different ages"):
        series.mean(1.0, 1.0)
    with pytest.raises(ValueError, match="outside the chronology"):
        series.mean(2.0, 4.0)
