"""Two maps at two scales (000 §6.3.1) as a user runs them: a coarse climate-run over Big
Tujunga written with --write-fluxes, and runs of a window of it with --inflow-from."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from tests.cli.test_bad_input import assert_refused
from tests.conftest import SHARED_DATA, run_cli

from unerode_cli.io.rasters import read_terrain

TUJUNGA = SHARED_DATA / "dem" / "sangabriel_bigtujunga" / "bigtujunga.tif"
LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
#: The coarse map: 12 × 10 km of the Big Tujunga DEM, the main stem crossing it east to west.
COARSE_BOX = "388000,3792000,400000,3802000"
#: The window, in cells of the coarse map (rows, columns): downstream, on the main stem.
WINDOW = (slice(50, 80), slice(20, 50))
RUN = ("--chronology", LR04, "--from", 0, "--to", 6, "--dt", 1000, "--process", "fluvial",
       "--K", 2e-5)


@pytest.fixture(scope="module")
def coarse(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The coarse run: the DEM averaged to 90 m, unerosion back to 6 ka, nesting rasters kept."""
    folder = tmp_path_factory.mktemp("coarse")
    dem = folder / "coarse90.tif"
    result = run_cli("convert", TUJUNGA, dem, "--crop", COARSE_BOX, "--cell-size", 90)
    assert result.returncode == 0, result.stderr
    result = run_cli("climate-run", dem, folder / "past.tif", *RUN, "--snapshots", "2,4",
                     "--write-fluxes")
    assert result.returncode == 0, result.stderr
    return folder / "past.tif"


def window_box(coarse_dem: Path) -> str:
    """The CRS box of ``WINDOW`` (cell edges)."""
    terrain = read_terrain(coarse_dem)
    rows, cols = WINDOW
    x0, y0 = terrain.transform @ (cols.start, rows.stop)
    x1, y1 = terrain.transform @ (cols.stop, rows.start)
    return f"{x0},{y0},{x1},{y1}"


def rmse_against_coarse(fine_past: Path, coarse_past: Path, factor: int) -> float:
    """RMSE (m) of the fine past surface averaged over blocks of ``factor`` × ``factor`` cells
    against the coarse past surface over the window, its boundary cells left out."""
    fine = read_terrain(fine_past).elevation
    ny, nx = fine.shape[0] // factor, fine.shape[1] // factor
    blocks = fine.reshape(ny, factor, nx, factor).mean(axis=(1, 3))
    parent = read_terrain(coarse_past).elevation[WINDOW]
    assert blocks.shape == parent.shape
    return float(np.sqrt(np.mean((blocks - parent)[1:-1, 1:-1] ** 2)))


def test_the_coarse_run_writes_its_nesting_rasters(coarse: Path) -> None:
    folder = coarse.with_name("past_fluxes")
    names = sorted(p.name for p in folder.iterdir())
    assert names == sorted(f"{field}_{age}ka.tif" for field in ("elevation", "discharge", "sediment_flux")
                           for age in (0, 2, 4, 6))
    start = read_terrain(folder / "elevation_0ka.tif")
    assert np.array_equal(start.elevation, read_terrain(coarse.with_name("coarse90.tif")).elevation)
    assert start.tags["UNERODE_AGE_KA"] == "0.0"
    assert np.array_equal(read_terrain(folder / "elevation_6ka.tif").elevation,
                          read_terrain(coarse).elevation)
    # water is conserved: what leaves through the edges (the outlets) is the phase's
    # precipitation over the whole map
    with open(coarse.with_name("past_timeline.csv"), newline="") as handle:
        precipitation = float(next(csv.DictReader(handle))["precipitation"])
    discharge = read_terrain(folder / "discharge_0ka.tif").elevation
    edges = np.ones(discharge.shape, dtype=bool)
    edges[1:-1, 1:-1] = False
    assert discharge[edges].sum() == pytest.approx(precipitation * discharge.size * 90.0 * 90.0,
                                                   rel=1e-6)


def test_a_window_at_the_same_cell_size_follows_its_coarse_run(coarse: Path) -> None:
    folder = coarse.parent
    window = folder / "window90.tif"
    assert run_cli("convert", coarse.with_name("coarse90.tif"), window, "--crop",
                   window_box(window.with_name("coarse90.tif"))).returncode == 0
    nested = run_cli("climate-run", window, folder / "nested90.tif", *RUN, "--inflow-from", coarse)
    assert nested.returncode == 0, nested.stderr
    assert "follow the coarse run's surface" in nested.stderr + nested.stdout
    alone = run_cli("climate-run", window, folder / "alone90.tif", *RUN)
    assert alone.returncode == 0, alone.stderr
    with_inflow = rmse_against_coarse(folder / "nested90.tif", coarse, 1)
    without = rmse_against_coarse(folder / "alone90.tif", coarse, 1)
    assert without >= 2.0 * with_inflow, (with_inflow, without)
    with open(folder / "nested90_timeline.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert all(float(row["inflow_discharge_m3_per_y"]) > 1e7 for row in rows)


def test_a_30_m_window_is_nearer_its_90_m_coarse_run_with_inflow(coarse: Path) -> None:
    """Across scales the agreement is limited by the stream power law's grid dependence (a
    30 m channel fills a third of a 90 m cell), so only the direction is asserted here."""
    folder = coarse.parent
    window = folder / "window30.tif"
    assert run_cli("convert", TUJUNGA, window, "--crop",
                   window_box(coarse.with_name("coarse90.tif"))).returncode == 0
    assert read_terrain(window).shape == (90, 90)
    for name, extra in (("nested30.tif", ("--inflow-from", coarse.with_name("past_fluxes"))),
                        ("alone30.tif", ())):
        result = run_cli("climate-run", window, folder / name, *RUN, *extra)
        assert result.returncode == 0, result.stderr
    with_inflow = rmse_against_coarse(folder / "nested30.tif", coarse, 3)
    without = rmse_against_coarse(folder / "alone30.tif", coarse, 3)
    assert with_inflow < 0.95 * without, (with_inflow, without)


@pytest.mark.parametrize("extra, mentions", [
    (("--process", "thermal"), "add fluvial to --process"),
    (("--edge-base", "coarse"), "give it with --inflow-from"),
    (("--inflow", "inflow.csv"), "not both"),
    (("--to", 8), "kept ages 0–6 ka, not the whole fine run from 0 to 8 ka"),
])
def test_bad_nesting_options_are_refused(coarse: Path, tmp_path: Path, extra: tuple,
                                         mentions: str) -> None:
    (tmp_path / "inflow.csv").write_text("x,y,discharge_m3_per_y,sediment_m3_per_y\n0,0,1,1\n")
    out = tmp_path / "past.tif"
    inflow_from = () if "--edge-base" in extra else ("--inflow-from", coarse)
    result = run_cli("climate-run", coarse.with_name("coarse90.tif"), out, *RUN, *inflow_from,
                     *extra, cwd=tmp_path)
    assert_refused(result, out, mentions)


def test_a_coarse_run_without_its_rasters_is_refused(coarse: Path, tmp_path: Path) -> None:
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", coarse.with_name("coarse90.tif"), out, *RUN, "--inflow-from",
                     coarse.with_name("past_2ka.tif"))
    assert_refused(result, out, "run the coarse climate-run with --write-fluxes")


def test_a_window_outside_the_coarse_map_is_refused(coarse: Path, tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere.tif"
    assert run_cli("convert", TUJUNGA, elsewhere, "--crop",
                   "380000,3792000,383000,3795000").returncode == 0
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", elsewhere, out, *RUN, "--inflow-from", coarse)
    assert_refused(result, out, "reaches outside the coarse run")


def test_write_fluxes_refuses_to_overwrite_them(coarse: Path, tmp_path: Path) -> None:
    out = coarse.with_name("again.tif")
    (coarse.parent / "again_fluxes").mkdir(exist_ok=True)
    (coarse.parent / "again_fluxes" / "discharge_6ka.tif").write_bytes(b"")
    result = run_cli("climate-run", coarse.with_name("coarse90.tif"), out, *RUN, "--write-fluxes")
    assert_refused(result, out, "discharge_6ka.tif already exists")
