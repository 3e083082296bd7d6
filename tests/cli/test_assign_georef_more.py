"""--crs, --cell-size and --nodata on `sandstone` and `compare-terraces`, and the georeferencing of
parameter rasters (``--K k.tif``): rasters without a CRS or geotransform are accepted with the
options and the outputs carry the CRS and grid assigned; a raster that contradicts them, or a
parameter raster off the DEM's grid, is refused in one sentence with exit code 2."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from pyproj import CRS
from rasterio.errors import NotGeoreferencedWarning
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff

from unerode_cli.io.rasters import read_terrain

ROWS, COLS = 12, 20
UTM32 = CRS.from_epsg(32632)
FAST_SANDSTONE = ("--particles", "6000", "--frames", "1", "--substeps", "20", "--settle-substeps", "400",
                  "-q")


def _bare(path: Path, data: np.ndarray) -> Path:
    """A GeoTIFF without CRS or geotransform (as a picture or a 3D tool writes it)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(path, "w", driver="GTiff", height=data.shape[0], width=data.shape[1], count=1,
                           dtype=data.dtype) as dst:
            dst.write(data, 1)
    return path


def _grid(cell: float, rows: int = ROWS) -> Affine:
    """The grid --cell-size assigns: ``cell`` m cells, lower-left corner at (0, 0)."""
    return Affine(cell, 0.0, 0.0, 0.0, -cell, rows * cell)


def _valley() -> np.ndarray:
    """A valley along row 6 falling west, 2 m per cell, with 5 m per cell side slopes (m)."""
    rows, cols = np.mgrid[0:ROWS, 0:COLS]
    return (100.0 + 2.0 * cols + 5.0 * np.abs(rows - 6)).astype(np.float32)


# --- sandstone ---------------------------------------------------------------------------------

def test_sandstone_extrudes_a_bare_dem_on_the_grid_and_crs_assigned(tmp_path: Path) -> None:
    rows, cols = np.mgrid[0:ROWS, 0:16]
    dem = (105.0 + 0.4 * cols + 0.2 * rows).astype(np.float32)
    source = _bare(tmp_path / "dem.tif", dem)
    out = tmp_path / "block"
    result = run_cli("sandstone", source, out, "--extrude", "100", "--crs", "EPSG:32632", "--cell-size", "10",
                     *FAST_SANDSTONE)
    assert result.returncode == 0, result.stderr
    with rasterio.open(out / "top.tif") as src:
        assert CRS.from_user_input(src.crs.to_wkt()) == UTM32
        assert src.transform.almost_equals(_grid(10.0))
        top = src.read(1).astype(np.float64)
    record = json.loads((out / "run.json").read_text())["parameters"]
    assert record["dem_transform"] == pytest.approx(list(_grid(10.0))[:6])
    # the rock is sampled on the assigned 10 m cells: the top follows the DEM within a spacing
    assert np.abs(top - dem).max() < record["lattice_spacing_m"]


@pytest.mark.parametrize(("args", "says"), [
    (("--crs", "EPSG:4326"), "already has a CRS"),
    (("--cell-size", "10"), "already has a geotransform"),
])
def test_sandstone_refuses_an_assignment_that_contradicts_the_dem(tmp_path: Path, args: tuple[str, ...],
                                                                   says: str) -> None:
    source = write_geotiff(tmp_path / "dem.tif", _valley())       # EPSG:32632, 30 m cells
    out = tmp_path / "block"
    assert_refused(run_cli("sandstone", source, out, "--extrude", "90", *args, *FAST_SANDSTONE), out, says)


def test_sandstone_refuses_georeferencing_for_a_preset(tmp_path: Path) -> None:
    out = tmp_path / "arch"
    assert_refused(run_cli("sandstone", "arch", out, "--crs", "EPSG:32632"), out, "apply to a DEM")


# --- compare-terraces --------------------------------------------------------------------------

def _terrace_case(folder: Path, present: Path, past: Path, x: float = 315.0, y: float = 165.0
                  ) -> tuple[object, ...]:
    """compare-terraces of ``present`` against one snapshot 10 ka old, with a terrace 3 m above
    the river at (``x``, ``y``): by default the centre of cell (6, 10) of 30 m cells from (0, 0)."""
    observations = folder / "terraces.csv"
    observations.write_text(f"age_ka,height_above_river_m,x,y\n10,3.0,{x},{y}\n")
    return ("compare-terraces", "--present", present, "--snapshots", past, "--auto-river",
            "--observations", observations, "--out", folder / "report")


def test_compare_terraces_reads_bare_rasters_on_the_grid_and_crs_assigned(tmp_path: Path) -> None:
    present = _bare(tmp_path / "present.tif", _valley())
    past = _bare(tmp_path / "valley_10ka.tif", _valley() + np.float32(3.0))
    result = run_cli(*_terrace_case(tmp_path, present, past), "--crs", "EPSG:32632", "--cell-size", "30")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    assert CRS.from_wkt(summary["grid"]["crs_wkt"]) == UTM32
    assert summary["grid"]["transform"] == pytest.approx(list(_grid(30.0))[:6])
    terrace = summary["terraces"]["rows"][0]
    # the point (315, 165) is the centre of cell (6, 10) on the assigned grid: on the river
    assert terrace["distance_to_river_m"] == pytest.approx(0.0, abs=1e-9)
    assert terrace["simulated_m"] == pytest.approx(3.0, abs=1e-4)
    # on 10 m cells the map spans 200 × 120 m: (315, 165) lies outside it, and the river is a
    # third as long
    ten = tmp_path / "ten"
    ten.mkdir()
    outside = run_cli(*_terrace_case(ten, present, past), "--crs", "EPSG:32632", "--cell-size", "10")
    assert outside.returncode == 2 and "lies outside the DEM" in outside.stderr, outside.stderr
    inside = run_cli(*_terrace_case(ten, present, past, 105.0, 55.0), "--crs", "EPSG:32632",
                     "--cell-size", "10")
    assert inside.returncode == 0, inside.stderr
    small = json.loads((ten / "report" / "summary.json").read_text())
    assert small["river"]["length_m"] == pytest.approx(summary["river"]["length_m"] / 3.0, rel=1e-9)
    assert small["terraces"]["rows"][0]["distance_to_river_m"] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize(("args", "says"), [
    (("--crs", "EPSG:4326"), "already has a CRS"),
    (("--cell-size", "10"), "already has a geotransform"),
])
def test_compare_terraces_refuses_an_assignment_that_contradicts_the_dem(
        tmp_path: Path, args: tuple[str, ...], says: str) -> None:
    present = write_geotiff(tmp_path / "present.tif", _valley())         # EPSG:32632, 30 m
    past = write_geotiff(tmp_path / "valley_10ka.tif", _valley() + np.float32(3.0))
    out = tmp_path / "report"
    assert_refused(run_cli(*_terrace_case(tmp_path, present, past), *args), out, says)


def test_compare_terraces_refuses_a_snapshot_in_another_crs(tmp_path: Path) -> None:
    present = _bare(tmp_path / "present.tif", _valley())
    past = write_geotiff(tmp_path / "valley_10ka.tif", _valley() + np.float32(3.0), _grid(30.0),
                         crs="EPSG:32633")
    out = tmp_path / "report"
    assert_refused(run_cli(*_terrace_case(tmp_path, present, past), "--crs", "EPSG:32632", "--cell-size",
                           "30"), out, "already has a CRS")


# --- parameter rasters -------------------------------------------------------------------------

def _erode(folder: Path, dem: Path, k: Path, *extra: object):
    """One fluvial step of 100 y on a ramp falling east, K from the raster ``k``."""
    return run_cli("erode", dem, folder / "out.tif", "--process", "fluvial", "--K", k, "--dt", 100,
                   "--steps", 1, "--outlets", "E", *extra)


def _ramp() -> np.ndarray:
    rows, cols = np.mgrid[0:ROWS, 0:COLS]
    return (200.0 - 3.0 * cols + 0.5 * np.sin(rows)).astype(np.float32)


def _k_map() -> np.ndarray:
    """K (m^(1-2m)/y): 0 in the 8 upstream (western) columns, 1e-4 downstream."""
    k = np.full((ROWS, COLS), 1e-4, dtype=np.float32)
    k[:, :8] = 0.0
    return k


def test_a_bare_parameter_raster_takes_the_crs_and_grid_assigned_to_the_dem(tmp_path: Path) -> None:
    dem = _bare(tmp_path / "dem.tif", _ramp())
    k = _bare(tmp_path / "k.tif", _k_map())
    result = _erode(tmp_path, dem, k, "--crs", "EPSG:32632", "--cell-size", "30")
    assert result.returncode == 0, result.stderr
    with rasterio.open(tmp_path / "out.tif") as src:
        assert CRS.from_user_input(src.crs.to_wkt()) == UTM32
        assert src.transform.almost_equals(_grid(30.0))
        change = src.read(1).astype(np.float64) - _ramp()
    # the map is read on the DEM's grid: no erosion where K is 0, erosion where it is not
    assert np.abs(change[:, :8]).max() == 0.0
    assert change[:, 8:-1].min() < -1e-3


def test_a_parameter_raster_without_crs_takes_the_dems_own(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "dem.tif", _ramp())                     # EPSG:32632, 30 m
    k = _bare(tmp_path / "k.tif", _k_map())
    result = _erode(tmp_path, dem, k)
    assert result.returncode == 0, result.stderr
    terrain = read_terrain(tmp_path / "out.tif")
    assert CRS.from_wkt(terrain.crs_wkt) == UTM32
    assert np.abs(terrain.elevation[:, :8] - _ramp()[:, :8]).max() == 0.0


@pytest.mark.parametrize(("make_k", "says"), [
    (lambda path: write_geotiff(path, _k_map(), _grid(30.0), crs="EPSG:32633"), "not in the DEM's CRS"),
    (lambda path: _bare(path, _k_map()[:-1]), "has 11 × 20 cells"),
    (lambda path: write_geotiff(path, _k_map(), _grid(10.0), crs=None), "not aligned with the DEM"),
])
def test_a_parameter_raster_off_the_dems_grid_is_refused(tmp_path: Path, make_k, says: str) -> None:
    dem = _bare(tmp_path / "dem.tif", _ramp())
    k = make_k(tmp_path / "k.tif")
    out = tmp_path / "out.tif"
    assert_refused(_erode(tmp_path, dem, k, "--crs", "EPSG:32632", "--cell-size", "30"), out, says)
