"""--inflow as a user runs it: rivers entering the map in erode, unerode and climate-run."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from rasterio.windows import Window
from tests.cli.test_bad_input import assert_refused
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

from unerode_cli.io.inflow_files import read_inflow
from unerode_cli.io.rasters import read_terrain

QS_IN = 2.0e3  # m³/y
HEADER = "x,y,discharge_m3_per_y,sediment_m3_per_y"
# the centre of the cell at row 1, column 10 of the ramp (one cell inside the north edge)
ENTRY = "500315,4999955"
TUJUNGA = SHARED_DATA / "dem" / "sangabriel_bigtujunga" / "bigtujunga.tif"


@pytest.fixture
def ramp(tmp_path: Path) -> Path:
    """24 × 20 cells of 30 m tilted towards the south edge, with small bumps."""
    rows, cols = np.indices((24, 20))
    z = 500.0 - 10.0 * rows + 3.0 * np.sin(cols * 0.9) * np.cos(rows * 0.7)
    return write_geotiff(tmp_path / "ramp.tif", z.astype(np.float32))


def inflow_file(tmp_path: Path, *rows: str, header: str = HEADER) -> Path:
    path = tmp_path / "inflow.csv"
    path.write_text("\n".join((header, *rows)) + "\n")
    return path


@pytest.mark.parametrize("command", ["erode", "unerode"])
def test_sidecar_budget_closes_with_the_inflow(tmp_path: Path, ramp: Path, command: str) -> None:
    table = inflow_file(tmp_path, f"{ENTRY},5e6,{QS_IN:g}")
    out = tmp_path / "out.tif"
    result = run_cli(command, ramp, out, "--dt", 100, "--steps", 4, "--outlets", "S", "--K", "1e-4",
                     "--K-d", "0.5", "--inflow", table)
    assert result.returncode == 0, result.stderr
    sidecar = json.loads((tmp_path / "out.tif.json").read_text())
    budget = sidecar["statistics"]["mass_budget_m3"]["fluvial"]
    sign = -1.0 if command == "unerode" else 1.0
    assert budget["inflow"] == pytest.approx(sign * 400.0 * QS_IN, rel=1e-12)
    assert abs(budget["residual"]) <= 1e-9 * max(budget["eroded"], budget["deposited"])
    assert sidecar["parameters"]["inflow"] == str(table)


@pytest.mark.parametrize(("rows", "header", "mentions"), [
    ((f"{ENTRY},1,1",), HEADER + ",width_m", "line 1: unknown column 'width_m'"),
    ((f"{ENTRY},1,1", "500315,4999655,1,1"), HEADER,
     "line 3: the point (500315, 4999655) snaps to the cell at row 11, column 10, more than one cell"),
    (("499990,4999955,1,1",), HEADER, "line 2: the point (499990, 4999955) is outside the map"),
    ((f"{ENTRY},1,-1",), HEADER, "line 2: sediment_m3_per_y must be ≥ 0"),
    ((f"{ENTRY},1,1,12", f"{ENTRY},2,1,20"), HEADER + ",age_ka", "an inflow through time needs climate-run"),
    ((f"{ENTRY},1,1,12", f"{ENTRY},2,1,12"), HEADER + ",age_ka", "line 3: the river at"),
    ((f"{ENTRY},1,1,",), HEADER + ",age_ka", "line 2: age_ka is empty"),
    (("500315,4999985,1,1",), HEADER,
     "line 2: the point (500315, 4999985) snaps to the cell at row 0, column 10, an outlet"),
])
def test_bad_inflow_tables_are_refused(tmp_path: Path, ramp: Path, rows: tuple[str, ...],
                                       header: str, mentions: str) -> None:
    out = tmp_path / "out.tif"
    table = inflow_file(tmp_path, *rows, header=header)
    result = run_cli("erode", ramp, out, "--steps", 1, "--inflow", table)
    assert_refused(result, out, mentions)
    assert str(table) in result.stderr


def test_a_point_on_nodata_snaps_to_the_nearest_valid_cell(tmp_path: Path, ramp: Path) -> None:
    terrain = read_terrain(ramp)
    terrain.elevation[8:14, 6:12] = np.nan  # a nodata hole inside the map
    # two rivers: in the hole, near its east side (row 10, column 11), and beside it
    table = inflow_file(tmp_path, "500340,4999685,1e6,10", "500375,4999685,2e6,5")
    inflow = read_inflow(table, terrain, np.zeros(terrain.shape, dtype=bool)).at()
    assert np.argwhere(inflow.discharge > 0).tolist() == [[10, 12]]
    assert inflow.discharge[10, 12] == 3e6 and inflow.sediment[10, 12] == 15.0


def test_inflow_needs_the_fluvial_process(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "out.tif"
    result = run_cli("erode", ramp, out, "--steps", 1, "--process", "thermal", "--inflow",
                     inflow_file(tmp_path, f"{ENTRY},1,1"))
    assert_refused(result, out, "add fluvial to --process")


def test_climate_run_reports_the_inflow(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", ramp, out, "--chronology", SHARED_DATA / "lr04" / "LR04stack.txt",
                     "--from", 0, "--to", 3, "--dt", 1000, "--process", "fluvial", "--outlets", "S",
                     "--inflow", inflow_file(tmp_path, f"{ENTRY},5e6,{QS_IN:g}"))
    assert result.returncode == 0, result.stderr
    with open(tmp_path / "past_timeline.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [float(r["inflow_m3"]) for r in rows] == pytest.approx([-1000.0 * QS_IN] * 3, rel=1e-12)
    sidecar = json.loads((tmp_path / "past.tif.json").read_text())
    assert sidecar["statistics"]["inflow_m3"] == pytest.approx(-3000.0 * QS_IN, rel=1e-12)


def test_big_tujunga_crop_with_the_main_stem_entering(tmp_path: Path) -> None:
    """128² cells of the San Gabriel DEM; Big Tujunga Creek (291 km² upstream) enters through
    the east edge with 1 m/y over its basin and 0.2 mm/y of erosion as sediment."""
    crop = tmp_path / "tujunga_128.tif"
    with rasterio.open(TUJUNGA) as src:
        window = Window(0, 400, 128, 128)
        profile = {**src.profile, "width": 128, "height": 128,
                    "transform": src.window_transform(window)}
        with rasterio.open(crop, "w", **profile) as dst:
            dst.write(src.read(1, window=window), 1)
    table = inflow_file(tmp_path, "380108.66,3793862.83,2.91e8,5.8e4")
    out = tmp_path / "tujunga_eroded.tif"
    result = run_cli("erode", crop, out, "--dt", 500, "--duration", 10000, "--inflow", table,
                     "--change-map", tmp_path / "dh.tif")
    assert result.returncode == 0, result.stderr
    budget = json.loads((tmp_path / "tujunga_eroded.tif.json").read_text())["statistics"][
        "mass_budget_m3"]["fluvial"]
    assert budget["inflow"] == pytest.approx(10000 * 5.8e4, rel=1e-12)
    assert abs(budget["residual"]) <= 1e-9 * (budget["eroded"] + budget["inflow"])
    dh = read_terrain(tmp_path / "dh.tif").elevation
    assert dh[60:76, 110:127].max() > 0.1  # the main stem deposits below where it enters
