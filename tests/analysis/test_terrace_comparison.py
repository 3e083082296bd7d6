"""compare-terraces: past riverbeds against dated terraces and incision rates (000 §6.3)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.conftest import run_cli, write_geotiff

from unerode_cli.analysis.history import river_history
from unerode_cli.analysis.incision import IncisionPeriod, compare_incision, snapshot_rates
from unerode_cli.analysis.river import auto_river, bed_profile
from unerode_cli.analysis.terraces import Terrace, compare_terraces, fit
from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask

DX = 30.0
NY, NX = 60, 41
THALWEG = 20
ORIGIN = Affine(DX, 0.0, 500000.0, 0.0, -DX, 5000000.0)
#: riverbed raised by RAISE[age]·(1 + row/NY) m at each snapshot age (ka)
RAISE = {10.0: 2.0, 30.0: 5.0, 60.0: 15.0}


def valley() -> np.ndarray:
    """A straight V-valley draining south along column THALWEG (m)."""
    rows, cols = np.mgrid[0:NY, 0:NX].astype(float)
    return 200.0 + 0.5 * (NY - rows) * DX * 0.05 + 0.3 * np.abs(cols - THALWEG) * DX


def snapshot(age: float) -> np.ndarray:
    """The valley with its floor (the thalweg column) raised by RAISE[age]·(1 + row/NY)."""
    z = valley()
    rows = np.arange(NY, dtype=float)
    z[:, THALWEG] += RAISE[age] * (1.0 + rows / NY)
    return z


def truth(age: float, row: np.ndarray | float) -> np.ndarray | float:
    return RAISE[age] * (1.0 + np.asarray(row) / NY) if age else 0.0 * np.asarray(row)


def main_stem():
    grid = Grid.full((NY, NX), DX)
    return auto_river(valley(), grid, outlet_mask(grid, "S"))


def test_auto_river_follows_the_thalweg_of_an_oblique_v_valley() -> None:
    ny, nx = 80, 60
    rows, cols = np.mgrid[0:ny, 0:nx].astype(float)
    thalweg = 12.0 + 0.45 * rows  # oblique to the grid
    z = 100.0 + 0.04 * (ny - rows) * DX + 0.25 * np.abs(cols - thalweg) * DX
    grid = Grid.full((ny, nx), DX)
    river = auto_river(z, grid, outlet_mask(grid, "S"))
    assert river.rows.size > 0.8 * ny
    offset = np.abs(river.cols - (12.0 + 0.45 * river.rows))
    assert offset.max() <= 1.0
    assert river.rows[0] == ny - 1  # downstream end first
    start = auto_river(z, grid, outlet_mask(grid, "S"), start=(5, 40))
    assert start.rows[-1] == 5 and start.cols[-1] == 40 and start.rows[0] == ny - 1


def test_heights_and_incision_rates_equal_the_truth() -> None:
    river = main_stem()
    assert np.all(river.cols == THALWEG)
    present = bed_profile(valley(), river, DX, DX)
    uplift = 1e-4  # m/y
    history = river_history(river.chainage, present,
                            [(age, bed_profile(snapshot(age), river, DX, DX)) for age in RAISE], uplift)
    for age in RAISE:
        expected = truth(age, river.rows) + uplift * age * 1000.0
        np.testing.assert_allclose(history.profile(age), expected, atol=1e-6)
    terraces = [
        Terrace(2, 30.0, 9.0, 1.0, "placed", chainage_m=float(river.chainage[10])),
        Terrace(3, 60.0, 20.0, None, "whole river"),
        Terrace(4, 20.0, 6.0, 0.5, "between snapshots", chainage_m=float(river.chainage[3])),
    ]
    results = compare_terraces(history, terraces)
    expected_30 = truth(30.0, river.rows[10]) + 3.0
    expected_60 = float(np.mean(truth(60.0, river.rows))) + 6.0
    expected_20 = 0.5 * (truth(10.0, river.rows[3]) + 1.0 + truth(30.0, river.rows[3]) + 3.0)
    assert results[0].simulated_m == pytest.approx(expected_30, abs=1e-6)
    assert results[1].simulated_m == pytest.approx(expected_60, abs=1e-6)
    assert results[2].simulated_m == pytest.approx(expected_20, abs=1e-6)
    residuals = np.array([expected_30 - 9.0, expected_60 - 20.0, expected_20 - 6.0])
    overall = fit(results)
    assert overall.rmse_m == pytest.approx(np.sqrt(np.mean(residuals**2)), abs=1e-9)
    assert overall.bias_m == pytest.approx(residuals.mean(), abs=1e-9)
    assert [r.within_uncertainty for r in results] == [abs(residuals[0]) <= 1.0, None,
                                                       abs(residuals[2]) <= 0.5]
    mean = {age: float(np.mean(truth(age, river.rows))) + uplift * age * 1000.0 for age in RAISE}
    period = IncisionPeriod(2, 60.0, 10.0, 100.0)
    (rate,) = compare_incision(history, [period])
    assert rate.simulated_mm_per_ka == pytest.approx((mean[60.0] - mean[10.0]) / 50.0 * 1000.0, abs=1e-6)
    old, young, rates = snapshot_rates(history)
    np.testing.assert_allclose(old, [10, 30, 60])
    np.testing.assert_allclose(rates[0], mean[10.0] / 10.0 * 1000.0, atol=1e-6)
    np.testing.assert_allclose(rates[2], (mean[60.0] - mean[30.0]) / 30.0 * 1000.0, atol=1e-6)


def test_uncovered_ages_name_the_line() -> None:
    river = main_stem()
    present = bed_profile(valley(), river, DX, DX)
    history = river_history(river.chainage, present, [(10.0, present + 1.0)])
    with pytest.raises(ValueError, match="line 7: age 12 ka is not covered"):
        compare_terraces(history, [Terrace(7, 12.0, 1.0)])
    with pytest.raises(ValueError, match="line 4: age 30 ka"):
        compare_incision(history, [IncisionPeriod(4, 30.0, 0.0, 5.0)])


# --- the command line ------------------------------------------------------------------------


def write_snapshots(folder: Path) -> list[Path]:
    """The present valley and three snapshots: two tagged like climate-run's, one named."""
    folder.mkdir()
    write_geotiff(folder.parent / "present.tif", valley(), ORIGIN)
    paths = []
    for age in RAISE:
        tagged = age != 30.0
        path = folder / (f"past_{age:g}.tif" if tagged else f"past_{age:g}ka.tif")
        write_geotiff(path, snapshot(age), ORIGIN)
        if tagged:
            with rasterio.open(path, "r+") as dst:
                dst.update_tags(UNERODE_AGE_KA=repr(age))
        paths.append(path)
    return paths


def xy_of(row: float, col: float) -> tuple[float, float]:
    return ORIGIN @ (col + 0.5, row + 0.5)


@pytest.fixture
def report_case(tmp_path: Path):
    write_snapshots(tmp_path / "snaps")
    x, y = xy_of(45, THALWEG + 1)  # one cell beside the river
    obs = tmp_path / "terraces.csv"
    obs.write_text(
        "# a comment line\n"
        "name,age_ka,height_above_river_m,uncertainty_m,x,y,chainage_m\n"
        f"A,10,3,1,{x},{y},\n"
        "B,60,20,5,,,\n"
        "C,30,9,,,,300\n",
        encoding="utf-8",
    )
    rates = tmp_path / "incision.csv"
    rates.write_text("from_ka,to_ka,rate_mm_per_ka,uncertainty_mm_per_ka\n60,30,300,50\n0,10,150,\n",
                     encoding="utf-8")
    return tmp_path, obs, rates


def test_compare_terraces_cli_writes_agreeing_report(report_case) -> None:
    tmp_path, obs, rates = report_case
    out = tmp_path / "report"
    result = run_cli("compare-terraces", "--present", tmp_path / "present.tif", "--snapshots",
                     tmp_path / "snaps", "--observations", obs, "--incision", rates, "--auto-river",
                     "--outlets", "S", "--out", out)
    assert result.returncode == 0, result.stderr
    assert "RMSE" in result.stdout
    summary = json.loads((out / "summary.json").read_text())
    with (out / "terraces.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert [row["name"] for row in rows] == ["A", "B", "C"]
    for row, js in zip(rows, summary["terraces"]["rows"], strict=True):
        assert float(row["simulated_m"]) == pytest.approx(js["simulated_m"], rel=1e-12)
        assert float(row["residual_m"]) == pytest.approx(js["simulated_m"] - js["observed_m"], abs=1e-9)
    # A lies one cell east of the river at row 45: its height is the river's there
    assert summary["terraces"]["rows"][0]["simulated_m"] == pytest.approx(truth(10.0, 45), abs=1e-6)
    assert summary["terraces"]["rows"][0]["distance_to_river_m"] == pytest.approx(DX)
    assert rows[0]["within_uncertainty"] == "True" and rows[2]["within_uncertainty"] == ""
    residuals = np.array([float(row["residual_m"]) for row in rows])
    assert summary["terraces"]["rmse_m"] == pytest.approx(np.sqrt(np.mean(residuals**2)), rel=1e-12)
    assert [s["age_ka"] for s in summary["snapshots"]] == [10.0, 30.0, 60.0]
    with (out / "incision.csv").open() as handle:
        periods = list(csv.DictReader(handle))
    assert float(periods[0]["simulated_mm_per_ka"]) == pytest.approx(
        summary["incision"]["periods"][0]["simulated_mm_per_ka"], rel=1e-12)
    for name in ("profiles.png", "incision.png"):
        png = out / name
        assert png.stat().st_size > 20_000
        import matplotlib.image

        image = matplotlib.image.imread(png)
        assert image.shape[0] > 300 and float(image[..., :3].std()) > 0.05
    with (out / "profiles.csv").open() as handle:
        profile = list(csv.DictReader(handle))
    assert set(profile[0]) == {"chainage_m", "height_0ka_m", "height_10ka_m", "height_30ka_m",
                               "height_60ka_m"}
    # a second run refuses to overwrite; --fail-above turns a large RMSE into exit code 3
    again = run_cli("compare-terraces", "--present", tmp_path / "present.tif", "--snapshots",
                    tmp_path / "snaps", "--observations", obs, "--auto-river", "--outlets", "S",
                    "--out", out)
    assert again.returncode == 2 and "--overwrite" in again.stderr
    gate = run_cli("compare-terraces", "--present", tmp_path / "present.tif", "--snapshots",
                   str(tmp_path / "snaps" / "past_*"), "--observations", obs, "--auto-river",
                   "--outlets", "S", "--out", out, "--overwrite", "--fail-above", "0.01")
    assert gate.returncode == 3, gate.stderr
    assert "above --fail-above" in gate.stderr


def test_river_line_in_geojson_is_turned_downstream_first(report_case) -> None:
    tmp_path, obs, _ = report_case
    top, bottom = xy_of(5, THALWEG), xy_of(NY - 1, THALWEG)
    line = tmp_path / "river.geojson"
    line.write_text(json.dumps({"type": "Feature", "properties": {}, "geometry": {
        "type": "LineString", "coordinates": [list(top), list(bottom)]}}))
    out = tmp_path / "report_line"
    result = run_cli("compare-terraces", "--present", tmp_path / "present.tif", "--snapshots",
                     tmp_path / "snaps", "--observations", obs, "--river", line, "--out", out)
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["river"]["length_m"] == pytest.approx((NY - 1 - 5) * DX)
    rows = summary["terraces"]["rows"]
    # C at chainage 300 m = 10 cells up from the mouth (row NY-1-10)
    assert rows[2]["simulated_m"] == pytest.approx(truth(30.0, NY - 11), abs=1e-6)


@pytest.mark.parametrize(("content", "message"), [
    ("age_ka,uncertainty_m\n10,1\n", "no 'height_above_river_m' column"),
    ("age_ka,height_above_river_m\n10,\n", "line 2: the required value 'height_above_river_m' is missing"),
    ("age_ka,height_above_river_m\n10,2\n500,3\n", "line 3: age 500 ka is not covered"),
    ("age_ka,height_above_river_m,x,y\n10,2,0,0\n", "line 2: the point (0, 0) lies outside the DEM"),
    ("age_ka,height_above_river_m,x\n10,2,500000\n", "line 2: give both x and y"),
    ("age_ka,height_above_river_m,heigth\n10,2,3\n", "unknown column 'heigth'"),
    ("age_ka,height_above_river_m\nten,2\n", "line 2: age_ka must be a number"),
])
def test_bad_observations_name_the_row(report_case, content: str, message: str) -> None:
    tmp_path, _, _ = report_case
    bad = tmp_path / "bad.csv"
    bad.write_text(content)
    out = tmp_path / "bad_report"
    result = run_cli("compare-terraces", "--present", tmp_path / "present.tif", "--snapshots",
                     tmp_path / "snaps", "--observations", bad, "--auto-river", "--outlets", "S",
                     "--out", out)
    assert result.returncode == 2
    assert message in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()
