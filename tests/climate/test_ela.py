"""The ELA through time from a chronology (001 §7 and Fig. 6, DESIGN §7): linear in the proxy
between present and the LGM, or following the temperature through a lapse rate, and the time
table a forward run takes. The LGM ages and values checked against the shared files are the
published ones: LR04 (Lisiecki & Raymo 2005) heaviest δ18O 5.02 ‰ at 18 ka; sea level ~−120 to
−130 m near 20–26 ka."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from tests.conftest import SHARED_DATA

from unerode_cli.climate.chronology import Series
from unerode_cli.climate.ela import (
    DEFAULT_ELA_M_PER_K,
    ELA_KINDS,
    ela_from_proxy,
    ela_from_temperature,
    ela_table,
    lgm,
)
from unerode_cli.errors import InputError
from unerode_cli.io.ela_files import read_ela_proxy

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
SPRATT = SHARED_DATA / "sealevel" / "spratt2016.txt"
BINTANJA = SHARED_DATA / "sealevel" / "bintanja_vandewal2008_3Myr.csv"

needs_lr04 = pytest.mark.skipif(not LR04.exists(), reason=f"no LR04 stack at {LR04}")
needs_spratt = pytest.mark.skipif(not SPRATT.exists(), reason=f"no Spratt 2016 file at {SPRATT}")
needs_bintanja = pytest.mark.skipif(not BINTANJA.exists(), reason=f"no Bintanja 2008 file at {BINTANJA}")

# 001 Fig. 6: E rises to 1700 m after the glacial maximum at 1200 m
PRESENT, GLACIAL = 1700.0, 1200.0


@needs_lr04
def test_lr04_present_and_lgm_give_the_two_elas(lr04):
    age, value = lgm(lr04, "d18o")
    assert 17.0 <= age <= 24.0
    assert age == pytest.approx(18.0) and value == pytest.approx(5.02)
    ela = ela_from_proxy(lr04, "d18o", PRESENT, GLACIAL, np.array([0.0, age]))
    assert ela[0] == pytest.approx(PRESENT, abs=1e-9)
    assert ela[1] == pytest.approx(GLACIAL, abs=1e-9)


@needs_lr04
def test_lr04_other_glacials_and_interglacials_are_extrapolated(lr04):
    # in LR04 the last interglacial peak (MIS 5e, 3.10 ‰ at 123 ka) is lighter than today
    # (3.23 ‰), MIS 6 (4.98 ‰ at 140 ka) close to the LGM and MIS 12 (5.08 ‰ at 433 ka) heavier
    ages = np.array([123.0, 140.0, 433.0])
    d18o = lr04.at(ages)
    np.testing.assert_allclose(d18o, [3.10, 4.98, 5.08], rtol=0, atol=1e-9)
    ela = ela_from_proxy(lr04, "d18o", PRESENT, GLACIAL, ages)
    assert ela[0] > PRESENT and ela[2] < GLACIAL
    assert ela[2] == pytest.approx(PRESENT + (GLACIAL - PRESENT) * (d18o[2] - 3.23) / (5.02 - 3.23))


def test_synthetic_series_gives_the_hand_computed_line():
    # δ18O 3.0 ‰ today, 5.0 ‰ at 20 ka, 4.0 ‰ at 10 ka, 5.5 ‰ at 40 ka (older, colder glacial)
    d18o = Series([0.0, 10.0, 20.0, 30.0, 40.0], [3.0, 4.0, 5.0, 4.5, 5.5], "d18o", "‰")
    assert lgm(d18o, "d18o") == (20.0, 5.0)
    ela = ela_from_proxy(d18o, "d18o", 2000.0, 1000.0, [5.0, 10.0, 25.0, 40.0])
    # 5 ka: 3.5 ‰ → 1/4 of the 1000 m drop; 10 ka: 4.0 ‰ → 1/2; 25 ka: 4.75 ‰ → 7/8;
    # 40 ka: 5.5 ‰ → 5/4 (below the glacial ELA)
    np.testing.assert_allclose(ela, [1750.0, 1500.0, 1125.0, 750.0], rtol=0, atol=1e-9)
    # sea level: lower is colder, the same curve mirrored
    sea = Series(d18o.age_ka, -40.0 * (d18o.value - 3.0), "sea", "m")
    assert lgm(sea, "sea-level") == (20.0, -80.0)
    np.testing.assert_allclose(ela_from_proxy(sea, "sea-level", 2000.0, 1000.0, [5.0, 10.0, 25.0, 40.0]),
                               ela, rtol=0, atol=1e-9)


def test_lgm_window_is_cut_to_the_series_and_its_ends_refused():
    temperature = Series([0.0, 10.0, 20.0, 25.0], [0.0, -4.0, -8.0, -6.0], "T", "K")
    # the window reaches past the series' 25 ka: cut there
    assert lgm(temperature, "temperature") == (20.0, -8.0)
    # the minimum of 10–19 ka is at 19 ka, an end: no glacial maximum in that window
    with pytest.raises(ValueError, match="at an end of the LGM window 10–19 ka"):
        lgm(temperature, "temperature", (10.0, 19.0))
    with pytest.raises(ValueError, match="does not reach into the LGM window 30–40 ka"):
        lgm(temperature, "temperature", (30.0, 40.0))
    with pytest.raises(ValueError, match="youngest first"):
        lgm(temperature, "temperature", (30.0, 14.0))
    with pytest.raises(ValueError, match="unknown ELA proxy kind 'generic'"):
        lgm(temperature, "generic")


def test_proxy_mapping_refusals():
    # heavier δ18O today (5.0 ‰) than at the LGM of the window (4.0 ‰ at 20 ka)
    heavy_today = Series([0.0, 10.0, 20.0, 40.0], [5.0, 3.0, 4.0, 3.0], "d18o", "‰")
    assert lgm(heavy_today, "d18o") == (20.0, 4.0)
    with pytest.raises(ValueError, match="not more glacial at its LGM"):
        ela_from_proxy(heavy_today, "d18o", 2000.0, 1000.0, [0.0])
    with pytest.raises(ValueError, match="below the present one"):
        ela_from_proxy(heavy_today, "sea-level", 1000.0, 2000.0, [0.0])
    with pytest.raises(ValueError, match="outside the chronology"):
        ela_from_proxy(heavy_today, "sea-level", 2000.0, 1000.0, [50.0])


def test_temperature_route_lowers_the_ela_by_the_lapse_rate():
    # a 5 K colder step from 10 ka on
    step = Series([0.0, 9.999, 10.0, 30.0], [1.0, 1.0, -4.0, -4.0], "T", "K")
    ela = ela_from_temperature(step, DEFAULT_ELA_M_PER_K, 1500.0, np.array([0.0, 5.0, 10.0, 20.0]))
    np.testing.assert_allclose(ela, [1500.0, 1500.0, 1500.0 - 5.0 * DEFAULT_ELA_M_PER_K,
                                     1500.0 - 5.0 * DEFAULT_ELA_M_PER_K], rtol=0, atol=1e-9)
    assert DEFAULT_ELA_M_PER_K == pytest.approx(153.85, abs=0.01)  # 1 / (6.5 K/km)
    assert ela_from_temperature(step, 100.0, 1500.0, 20.0) == pytest.approx(1000.0)
    for bad in (0.0, -154.0, float("nan")):
        with pytest.raises(ValueError, match="finite positive number of m per K"):
            ela_from_temperature(step, bad, 1500.0, [0.0])


@needs_spratt
def test_spratt_sea_level_lgm(spratt):
    age, value = lgm(spratt, "sea-level")
    # −130 m relative to Spratt's 5 ka reference, −139 m once 0 ka is anchored at 0 m
    assert 20.0 <= age <= 26.0 and age == pytest.approx(24.0)
    assert value == pytest.approx(-138.96, abs=0.01)
    ela = ela_from_proxy(spratt, "sea-level", PRESENT, GLACIAL, [0.0, age])
    np.testing.assert_allclose(ela, [PRESENT, GLACIAL], rtol=0, atol=1e-9)


@needs_bintanja
def test_bintanja_sea_level_temperature_and_d18o_lgms(bintanja):
    age, value = lgm(bintanja, "sea-level")
    assert 19.0 <= age <= 26.0 and value == pytest.approx(-120.0, abs=5.0)
    assert (age, value) == pytest.approx((19.8, -121.9512))
    temperature = read_ela_proxy(BINTANJA, "temperature")
    assert (temperature.name, temperature.unit) == ("Tsurf", "K")
    t_age, t_value = lgm(temperature, "temperature")
    assert (t_age, t_value) == pytest.approx((19.6, -15.936))
    # the anomaly is −0.048 K at 0 ka: the ELA is E0 there all the same
    ela = ela_from_temperature(temperature, DEFAULT_ELA_M_PER_K, PRESENT, [0.0, t_age])
    np.testing.assert_allclose(ela, [PRESENT, PRESENT + DEFAULT_ELA_M_PER_K * (-15.936 + 0.0479)],
                               rtol=0, atol=1e-6)
    d18o = read_ela_proxy(BINTANJA, "d18o")  # Iso_tot, the δ18O anomaly
    assert d18o.name == "Iso_tot"
    assert lgm(d18o, "d18o") == pytest.approx((18.9, 1.7411))


def test_read_ela_proxy_columns(tmp_path):
    two = tmp_path / "two.txt"
    two.write_text("0 14.0\n10 12.0\n20 6.0\n30 9.0\n")
    series = read_ela_proxy(two, "temperature")
    assert series.unit == "K" and lgm(series, "temperature") == (20.0, 6.0)
    many = tmp_path / "many.csv"
    many.write_text("age,a,b\n0,1,2\n10,3,4\n")
    with pytest.raises(InputError, match="say which one"):
        read_ela_proxy(many, "temperature")
    assert read_ela_proxy(many, "temperature", "b").value.tolist() == [2.0, 4.0]
    with pytest.raises(InputError, match="unknown ELA proxy kind"):
        read_ela_proxy(two, "precipitation")


def test_ela_table_ends_samples_and_times():
    ages = np.array([0.0, 5.0, 10.0, 15.0, 20.0, 25.0])
    ela = np.array([1700.0, 1600.0, 1500.0, 1400.0, 1300.0, 1200.0])
    times, values = ela_table(ages, ela, 22.0, 2.5)
    np.testing.assert_allclose(times, [0.0, 2000.0, 7000.0, 12000.0, 17000.0, 19500.0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(values, [1260.0, 1300.0, 1400.0, 1500.0, 1600.0, 1650.0], rtol=0, atol=1e-9)
    assert times.dtype == values.dtype == np.float64
    assert np.all(np.diff(times) > 0)
    # ends on samples are not doubled; the whole chronology is accepted
    times, values = ela_table(ages, ela, 25.0, 0.0)
    np.testing.assert_array_equal(times, [0.0, 5000.0, 10000.0, 15000.0, 20000.0, 25000.0])
    np.testing.assert_array_equal(values, ela[::-1])


def test_ela_table_refusals():
    ages, ela = [0.0, 10.0, 20.0], [1700.0, 1400.0, 1200.0]
    span = r"lr04\.txt covers 0–20 ka, which does not span the run from 30 ka to 5 ka"
    with pytest.raises(ValueError, match=span):
        ela_table(ages, ela, 30.0, 5.0, source="lr04.txt")
    with pytest.raises(ValueError, match="covers 0–20 ka, which does not span the run from 10 ka to -1 ka"):
        ela_table(ages, ela, 10.0, -1.0)
    for start, end in ((5.0, 10.0), (5.0, 5.0)):
        with pytest.raises(ValueError, match=f"from {start:g} ka to {end:g} ka"):
            ela_table(ages, ela, start, end)


@needs_lr04
def test_ela_table_from_lr04(lr04):
    ela = ela_from_proxy(lr04, "d18o", PRESENT, GLACIAL, lr04.age_ka)
    times, values = ela_table(lr04.age_ka, ela, 24.5, 0.0, source=str(LR04))
    assert times[0] == 0.0 and times[-1] == pytest.approx(24500.0)
    assert np.all(np.diff(times) > 0)
    assert values[-1] == pytest.approx(PRESENT, abs=1e-9)
    assert values[0] == pytest.approx(float(ela_from_proxy(lr04, "d18o", PRESENT, GLACIAL, 24.5)))
    assert values.min() == pytest.approx(GLACIAL, abs=1e-9)  # 18 ka is in the table
    inside = lr04.age_ka[(lr04.age_ka > 0.0) & (lr04.age_ka < 24.5)]
    assert times.size == inside.size + 2


@given(st.lists(st.floats(-5.0, 5.0), min_size=2, max_size=30), st.floats(500.0, 3000.0),
       st.floats(1.0, 2000.0), st.sampled_from(ELA_KINDS))
def test_ela_is_monotonic_in_the_proxy(values, present, drop, kind):
    # a series with a clear LGM at 20 ka (more glacial than anything else) and any values elsewhere
    sign = 1.0 if kind == "d18o" else -1.0
    ages = np.concatenate(([0.0, 20.0], 40.0 + np.arange(len(values))))
    proxy = np.concatenate(([0.0, 10.0 * sign], values))
    series = Series(ages, proxy)
    ela = ela_from_proxy(series, kind, present, present - drop, ages)
    order = np.argsort(sign * proxy, kind="stable")  # warmest first
    assert np.all(np.diff(ela[order]) <= 1e-9 * present)
