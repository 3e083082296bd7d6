"""climate-run --process glacial,…: glaciate's coupled glacier model (001) forward along the
chronology that also gives the sea level (000 §5), and the runs it refuses."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.cli.test_bad_input import assert_refused
from tests.cli.test_glaciate_command import DX, _transform
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

from unerode_cli.io.rasters import read_terrain

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
pytestmark = pytest.mark.skipif(not LR04.exists(), reason="needs ../shared/data")
#: 22 → 20 ka in 100-year steps, the ELA 3200 m today and 2200 m at the LGM (LR04: 5.02 ‰, 18 ka).
ALONG = ("--from", 22, "--to", 20, "--dt", 100, "--ela-present", 3200, "--ela-glacial", 2200)


def massif(n: int = 24) -> np.ndarray:
    """A round massif of 100 m cells on a plain at 1200 m, its summit near 2840 m, with small
    ridges: inland (no cell near sea level), its top above an ELA of about 2300 m."""
    y, x = np.mgrid[0:n, 0:n] * DX
    centre = (n - 1) * DX / 2
    r = np.hypot(x - centre, y - centre)
    return (1200.0 + 1600.0 * np.exp(-(r / (0.35 * n * DX)) ** 2)
            + 60.0 * np.sin(x / 300.0) * np.cos(y / 400.0))


@pytest.fixture
def dem(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "massif.tif", massif().astype(np.float32), _transform(DX))


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_glaciers_along_the_chronology_are_glaciate_with_the_sea_level_of_climate_run(
        tmp_path: Path, dem: Path) -> None:
    past, glaciated, rivers = tmp_path / "past.tif", tmp_path / "glaciated.tif", tmp_path / "rivers.tif"
    along = ("--chronology", LR04, "--process", "glacial,hillslope,debris,fluvial", *ALONG, "--preview",
             tmp_path / "past.png")
    stopped = run_cli("climate-run", dem, past, *along, "--max-steps", 12)  # then resumed: same result
    assert stopped.returncode == 0 and "stopped after step 12" in stopped.stderr + stopped.stdout
    result = run_cli("climate-run", dem, past, *along, "--resume")
    assert result.returncode == 0, result.stderr
    same = run_cli("glaciate", dem, glaciated, "--ela-chronology", LR04, *ALONG,
                   "--timeline", tmp_path / "glaciated.csv")
    assert same.returncode == 0, same.stderr
    # the climate-run of the same chronology without glaciers: its sea level at 21 and 20 ka
    plain = run_cli("climate-run", dem, rivers, "--chronology", LR04, "--process", "fluvial",
                    "--from", 22, "--to", 20, "--dt", 1000)
    assert plain.returncode == 0, plain.stderr

    before, bed = read_terrain(dem).elevation, read_terrain(past).elevation
    np.testing.assert_allclose(bed, read_terrain(glaciated).elevation, rtol=0, atol=1e-3)
    assert 1.0 < (before - bed).max() < 100.0        # the glaciers eroded metres in 2000 y
    timeline, glaciate_timeline = rows(tmp_path / "past_timeline.csv"), rows(tmp_path / "glaciated.csv")
    assert len(timeline) == len(glaciate_timeline) > 20
    for ours, theirs in zip(timeline, glaciate_timeline, strict=True):
        assert {k: float(v) for k, v in ours.items() if k != "sea_level_m"} == pytest.approx(
            {k: float(v) for k, v in theirs.items()}, rel=1e-9, abs=1e-6)
    assert float(timeline[-1]["ice_volume_m3"]) > 1e7  # ice formed: ~0.03 km³
    sea = {round(float(r["age_ka"]), 6): float(r["sea_level_m"]) for r in timeline}
    for row in rows(tmp_path / "rivers_timeline.csv"):
        assert sea[round(float(row["age_ka"]), 6)] == pytest.approx(float(row["sea_level_m"]), abs=1e-9)
    assert -130.0 < sea[20.0] < -100.0               # LR04 near the LGM through climate-run's mapping
    # the summary names both forcings: the ELA of the steps and the sea level, from 22 to 20 ka
    forcing = re.search(r"ELA (\d+)–(\d+) m, sea level (\S+) to (\S+) m", result.stderr)
    assert forcing is not None, result.stderr
    ela = [float(r["ela_m"]) for r in timeline]
    assert [float(v) for v in forcing.groups()] == pytest.approx(
        [min(ela), max(ela), min(sea.values()), max(sea.values())], abs=0.51)
    with rasterio.open(past) as src:
        tags = src.tags()
    assert float(tags["UNERODE_AGE_KA"]) == pytest.approx(20.0)
    assert float(tags["UNERODE_SEA_LEVEL_M"]) == pytest.approx(sea[20.0], abs=1e-9)
    assert (tmp_path / "past_chronology.png").stat().st_size > 10_000
    assert (tmp_path / "past.png").stat().st_size > 1_000


@pytest.mark.parametrize("args, words", [
    (("--process", "glacial", "--from", 0, "--to", 20, "--ela-present", 3200, "--ela-glacial", 2200),
     "glaciers run forward in time only"),
    (("--process", "glacial,thermal", *ALONG), "thermal cannot run with glacial"),
    (("--process", "glacial,fluvial", "--from", 25, "--to", 20, "--ela-glacial", 2200),
     "needs --ela-present and --ela-glacial"),
    (("--process", "fluvial", "--from", 25, "--to", 20, "--ela-present", 3200), "add glacial to --process"),
    (("--process", "fluvial", "--from", 25, "--to", 20, "--k-f", 1e-6), "--k-f is a parameter of"),
    (("--process", "glacial", *ALONG, "--K", 1e-5), "--k does not apply with --process glacial"),
    (("--process", "glacial", *ALONG, "--snapshots", 22), "--snapshots does not apply"),
    (("--process", "glacial", *ALONG, "--outlets", "S"), "--outlets does not apply"),
    (("--process", "fluvial", "--from", 25, "--to", 20, "--iceflow", "cnn"),
     "--iceflow and --seed set the glaciers' ice flow; add glacial to --process"),
])
def test_runs_the_glaciers_cannot_make_are_refused(tmp_path: Path, dem: Path, args: tuple,
                                                    words: str) -> None:
    out = tmp_path / "past.tif"
    assert_refused(run_cli("climate-run", dem, out, "--chronology", LR04, *args), out, words)


@pytest.mark.slow
def test_the_glaciers_of_climate_run_take_the_cnn_ice_flow(tmp_path: Path, dem: Path) -> None:
    """--iceflow cnn (001 §4) in climate-run's glaciers: every velocity solve is the network's
    prediction, finished by the converged solver where it misses the tolerance (counted in the
    summary and sidecar), so the bed after 300 y is the converged solver's to within the
    solver's tolerance (the largest difference under 2 % of the largest erosion); --seed is
    recorded in the history. Slow: 8 steps take about 70 s with the network on a busy core,
    against 3 s for the converged solver alone."""
    pytest.importorskip("torch")
    along = ("--chronology", LR04, "--process", "glacial", "--from", 22, "--to", 21.7, "--dt", 100,
             "--ela-present", 3200, "--ela-glacial", 2200)
    cnn = run_cli("climate-run", dem, tmp_path / "cnn.tif", *along, "--iceflow", "cnn", "--seed", 3)
    assert cnn.returncode == 0, cnn.stderr
    blatter = run_cli("climate-run", dem, tmp_path / "blatter.tif", *along)
    assert blatter.returncode == 0, blatter.stderr
    assert "CNN:" in cnn.stderr and "CNN:" not in blatter.stderr
    sidecar = json.loads((tmp_path / "cnn.tif.json").read_text())
    stats = sidecar["statistics"]
    assert stats["cnn_solves"] >= 3
    assert stats["cnn_met_tolerance"] + stats["cnn_takeovers"] == stats["cnn_solves"]
    assert sidecar["seed"] == 3 and sidecar["parameters"]["iceflow"] == "cnn"
    before = read_terrain(dem).elevation
    ours = read_terrain(tmp_path / "cnn.tif").elevation
    theirs = read_terrain(tmp_path / "blatter.tif").elevation
    eroded = (before - theirs).max()
    assert eroded > 0.05
    assert np.abs(ours - theirs).max() < 0.02 * eroded


def test_an_uplift_table_is_refused_with_glaciers(tmp_path: Path, dem: Path) -> None:
    table = tmp_path / "uplift.csv"
    table.write_text("age_ka,U_m_per_y\n0,0.001\n30,0.002\n")
    out = tmp_path / "past.tif"
    assert_refused(run_cli("climate-run", dem, out, "--chronology", LR04, "--process", "glacial",
                           *ALONG, "--uplift", table), out, "not a table through time")
