"""climate-run boundaries as a user sets them: an inland DEM keeps its edges through the last
glacial maximum, a coast follows sea level, other edges rise with the uplift or follow a table."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.cli import test_climate_run
from tests.cli.test_bad_input import assert_refused
from tests.cli.test_climate_run import LR04, SPRATT, read_timeline
from tests.conftest import run_cli

from unerode_cli.io.rasters import read_terrain

#: The fixture of an inland DEM: a 30 × 16 ramp, 4.5 m at its lowest, tilted to the south edge.
ramp = test_climate_run.ramp

#: 20 steps of the real chronology back to the last glacial maximum, kept exactly (float64).
RUN = ("--chronology", LR04, "--sea-level", SPRATT, "--from", 0, "--to", 20, "--dt", 1000,
       "--process", "fluvial", "--K", "1e-4", "--uplift", "1e-4", "--dtype", "float64")
#: Years from 0 to 20 ka, negative backward in time.
ELAPSED_Y = -20000.0


def edges(shape: tuple[int, int]) -> np.ndarray:
    """bool mask of the four domain edges."""
    mask = np.ones(shape, dtype=bool)
    mask[1:-1, 1:-1] = False
    return mask


def test_an_inland_dem_keeps_its_edges_through_the_glacial_maximum(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", ramp, out, *RUN)
    assert result.returncode == 0, result.stderr
    h0, h = read_terrain(ramp).elevation, read_terrain(out).elevation
    border = edges(h0.shape)
    np.testing.assert_allclose(h[border], h0[border], rtol=0, atol=1e-9)
    assert np.abs(h - h0)[~border].max() > 1.0  # the interior did change
    assert "0 coast-edge and 0 sea cells follow sea level, 88 edge cells keep their elevation" \
        in result.stderr
    statistics = json.loads((tmp_path / "past.tif.json").read_text())["statistics"]
    assert statistics["boundaries"] == {"sea_cells": 0, "coast_edge_cells": 0, "fixed_edge_cells": 88,
                                        "uplift_edge_cells": 0, "table_edge_cells": 0,
                                        "coarse_edge_cells": 0}


def test_a_coast_follows_sea_level_while_the_other_edges_rise_with_the_uplift(tmp_path: Path,
                                                                              ramp: Path) -> None:
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", ramp, out, *RUN, "--coast", "S", "--edge-base", "uplift")
    assert result.returncode == 0, result.stderr
    sea_20 = float(read_timeline(tmp_path / "past_timeline.csv")[-1]["sea_level_m"])
    assert sea_20 == pytest.approx(-120.0, abs=20.0)
    h0, h = read_terrain(ramp).elevation, read_terrain(out).elevation
    np.testing.assert_allclose(h[-1], h0[-1] + sea_20, rtol=0, atol=1e-9)  # Spratt: 0 m at 0 ka
    inland = edges(h0.shape)
    inland[-1] = False
    np.testing.assert_allclose(h[inland], h0[inland] + 1e-4 * ELAPSED_Y, rtol=0, atol=1e-9)
    assert "16 coast-edge and 0 sea cells follow sea level, 72 edge cells rise with the uplift" \
        in result.stderr


def test_edges_follow_a_base_level_table_from_a_coarser_run(tmp_path: Path, ramp: Path) -> None:
    table = tmp_path / "outlet_level.csv"
    table.write_text("# river level at the outlet of a coarser run\nage_ka,elevation_m\n"
                     "30,200\n10,240\n0,250\n")
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", ramp, out, *RUN, "--edge-base", table, "--snapshots", 10)
    assert result.returncode == 0, result.stderr
    h0 = read_terrain(ramp).elevation
    border = edges(h0.shape)
    for path, drop in ((tmp_path / "past_10ka.tif", -10.0), (out, -30.0)):  # T(age) − T(0)
        h = read_terrain(path).elevation
        np.testing.assert_allclose(h[border], h0[border] + drop, rtol=0, atol=1e-9)
    assert "88 edge cells follow the --edge-base table" in result.stderr


def test_bad_boundaries_are_refused_before_any_work(tmp_path: Path, ramp: Path) -> None:
    table = tmp_path / "short.csv"
    table.write_text("age_ka,elevation_m\n0,250\n10,240\n")
    out = tmp_path / "past.tif"
    assert_refused(run_cli("climate-run", ramp, out, *RUN, "--edge-base", table), out,
                   "covers 0–10 ka, not the whole run from 0 to 20 ka")
    assert_refused(run_cli("climate-run", ramp, out, *RUN, "--coast", "SW"), out, "--coast must be")
