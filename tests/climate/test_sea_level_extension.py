"""A sea-level table continued with δ18O beyond its oldest age (``--sea-level-extend d18o``):
the line is the least-squares fit over the overlap (recomputed here with NumPy's polyfit), its
residual RMS is the one the docstring states, the curve is continuous at the join and is the
line itself past the taper, and a climate-run asking for 820 ka with Spratt & Lisiecki 2016
(798 ka) runs to 820 ka instead of stopping."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from tests.cli.test_bad_input import assert_refused
from tests.climate.conftest import LR04, SPRATT
from tests.conftest import run_cli, write_geotiff

from unerode_cli.climate.sealevel import JOIN_TAPER_KA, extend_with_d18o, residual_rms

pytestmark = pytest.mark.skipif(not (LR04.is_file() and SPRATT.is_file()), reason="needs ../shared/data")


def overlap_line(lr04, spratt) -> tuple[float, float, float]:
    """(slope m/‰, intercept m, residual RMS m) of Spratt against LR04 at Spratt's ages."""
    x = np.interp(spratt.age_ka, lr04.age_ka, lr04.value)
    slope, intercept = np.polyfit(x, spratt.value, 1)
    residual = spratt.value - intercept - slope * x
    return float(slope), float(intercept), float(np.sqrt(np.mean(residual**2)))


def test_the_line_and_its_residual_are_those_stated(lr04, spratt) -> None:
    slope, intercept, rms = overlap_line(lr04, spratt)
    extended = extend_with_d18o(spratt, lr04)
    print(f"sea = {intercept:.3f} m {slope:+.4f} m/‰ · δ18O, residual RMS {rms:.3f} m; {extended.note}")
    assert slope == pytest.approx(-65.05, abs=0.01)           # the docstring's numbers
    assert intercept == pytest.approx(209.35, abs=0.01)
    assert rms == pytest.approx(14.67, abs=0.01)
    from unerode_cli.climate.sealevel import fit_mapping
    assert residual_rms(lr04, spratt, fit_mapping(lr04, spratt)) == pytest.approx(rms, rel=1e-9)
    # past the taper the extension is the line itself
    ages = np.arange(spratt.end_ka + JOIN_TAPER_KA, 1200.0, 1.0)
    np.testing.assert_allclose(extended.at(ages), intercept + slope * lr04.at(ages), atol=1e-6)
    # inside the table, the table
    np.testing.assert_array_equal(extended.at(spratt.age_ka), spratt.value)
    assert extended.end_ka == lr04.end_ka


def test_the_extended_curve_is_continuous_at_the_join(lr04, spratt) -> None:
    slope, intercept, _ = overlap_line(lr04, spratt)
    extended = extend_with_d18o(spratt, lr04)
    join = spratt.end_ka                                            # 798 ka
    residual = spratt.value[-1] - (intercept + slope * lr04.at(join))
    assert residual == pytest.approx(-6.23, abs=0.01)               # the docstring's number
    # the value at the join is the table's, and just past it the line plus the whole residual
    assert extended.at(join) == spratt.value[-1]
    eps = 1e-6
    assert extended.at(join + eps) == pytest.approx(spratt.value[-1], abs=1e-3)
    # the steps across the join are no larger than the table's own steps over its last 100 ka
    steps = np.abs(np.diff(extended.at(np.arange(join - 4.0, join + 12.0, 1.0))))
    assert steps.max() <= np.abs(np.diff(spratt.at(np.arange(join - 100.0, join + 1e-9, 1.0)))).max()
    # the taper: half the residual is left halfway
    half = join + JOIN_TAPER_KA / 2
    assert extended.at(half) == pytest.approx(intercept + slope * lr04.at(half) + residual / 2, abs=1e-6)


def test_a_table_that_reaches_the_end_of_the_d18o_table_is_kept(lr04, spratt) -> None:
    assert extend_with_d18o(spratt, spratt) is spratt
    with pytest.raises(ValueError, match="positive number of ka"):
        extend_with_d18o(spratt, lr04, taper_ka=0.0)


def valley(tmp_path: Path) -> Path:
    rows, cols = np.mgrid[0:24, 0:20].astype(float)
    heights = 2.0 + 4.0 * rows + 3.0 * np.abs(cols - 10.0)           # a V-valley draining north
    return write_geotiff(tmp_path / "valley.tif", heights.astype(np.float32))


def test_a_run_to_820_ka_no_longer_stops_at_798_ka(tmp_path: Path, lr04, spratt) -> None:
    dem = valley(tmp_path)
    common = ["--chronology", LR04, "--sea-level", SPRATT, "--to", "820", "--dt", "10000"]
    refused = run_cli("climate-run", dem, tmp_path / "cut.tif", *common)
    assert_refused(refused, tmp_path / "cut.tif", "--sea-level-extend d18o")
    result = run_cli("climate-run", dem, tmp_path / "past.tif", *common, "--sea-level-extend", "d18o")
    assert result.returncode == 0, result.stderr
    with (tmp_path / "past_timeline.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert float(rows[-1]["age_ka"]) == 820.0 and len(rows) == 82
    slope, intercept, _ = overlap_line(lr04, spratt)
    assert float(rows[-1]["sea_level_m"]) == pytest.approx(intercept + slope * lr04.at(820.0), abs=1e-6)
    at_790 = next(row for row in rows if float(row["age_ka"]) == 790.0)
    assert float(at_790["sea_level_m"]) == pytest.approx(spratt.at(790.0), abs=1e-9)


def test_extend_needs_a_table_and_a_d18o_chronology(tmp_path: Path) -> None:
    dem = valley(tmp_path)
    out = tmp_path / "past.tif"
    assert_refused(run_cli("climate-run", dem, out, "--chronology", LR04, "--sea-level-extend", "d18o"),
                   out, "give both")
    assert_refused(run_cli("climate-run", dem, out, "--chronology", SPRATT, "--chronology-kind", "sea-level",
                           "--sea-level", SPRATT, "--sea-level-extend", "d18o"), out, "give both")
