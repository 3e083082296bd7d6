"""`glaciate` along a paleo-climate chronology: the ELA mapping, the timeline, lakes, refusals."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from tests.cli.test_bad_input import assert_refused
from tests.cli.test_glaciate_command import DX, _transform, valley
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

from unerode_cli.climate import ela as ela_model
from unerode_cli.io.ela_files import read_ela_proxy
from unerode_cli.io.rasters import read_terrain

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
pytestmark = pytest.mark.skipif(not LR04.exists(), reason="needs ../shared/data")


@pytest.fixture
def small_valley(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "valley.tif", valley(16, 24).astype(np.float32), _transform(DX))


def test_the_timeline_follows_the_lr04_mapping_to_today(tmp_path: Path, small_valley: Path) -> None:
    out, timeline, lakes = tmp_path / "bed.tif", tmp_path / "t.csv", tmp_path / "lakes.tif"
    result = run_cli("glaciate", small_valley, out, "--ela-chronology", LR04, "--ela-present", 3000,
                     "--ela-glacial", 2000, "--from", 0.3, "--to", 0, "--dt", 50, "--layers", 4,
                     "--timeline", timeline, "--lakes", lakes)
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader(timeline.open()))
    ages = np.array([float(r["age_ka"]) for r in rows])
    assert ages[-1] == pytest.approx(0.0, abs=1e-12) and np.all(np.diff(ages) < 0)
    ends = np.array([float(r["time_y"]) for r in rows])
    starts = np.concatenate([[0.0], ends[:-1]])                 # each row: the ELA of its step's start
    series = read_ela_proxy(LR04, "d18o")
    expected = ela_model.ela_from_proxy(series, "d18o", 3000.0, 2000.0, 0.3 - starts / 1e3)
    assert [float(r["ela_m"]) for r in rows] == pytest.approx(expected, abs=1e-6)
    assert float(rows[-1]["ice_volume_m3"]) > 0
    assert (tmp_path / "bed_chronology.png").stat().st_size > 10_000   # proxy, ELA, ice volume
    bed_stats = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]
    parts = bed_stats["wall_time_by_part_s"]   # where the time went: ice flow, transport, …
    assert set(parts) == {"ice_flow", "transport_erosion", "ice_free", "other"}
    assert sum(parts.values()) == pytest.approx(bed_stats["wall_time_s"], rel=0.05)
    assert sum(bed_stats["ice_free_wall_time_s"].values()) == pytest.approx(parts["ice_free"], rel=0.05)
    stats = json.loads((tmp_path / "lakes.tif.json").read_text())["statistics"]["lakes"]
    depth = read_terrain(lakes).elevation
    assert stats["area_m2"] == pytest.approx(np.count_nonzero(depth > 0) * DX * DX, rel=0.5, abs=DX * DX)


def test_at_present_the_ela_is_the_present_one_and_at_the_lgm_the_glacial_one() -> None:
    series = read_ela_proxy(LR04, "d18o")
    age, _ = ela_model.lgm(series, "d18o")
    values = ela_model.ela_from_proxy(series, "d18o", 2900.0, 1500.0, [0.0, age])
    assert values == pytest.approx([2900.0, 1500.0], abs=1e-9)


@pytest.mark.parametrize("extra, words", [
    (("--from", 6000), "does not span"),
    (("--from", 10, "--ela", 3000), "drop --ela"),
    (("--from", 10, "--ela-lapse-rate", 150), "--ela-kind temperature"),
    (("--from", 10, "--ela-glacial", 2000, "--ela-lapse-rate", 150), "one of --ela-glacial"),
    (("--ela-glacial", 2000, "--from", 10, "--shield-thickness", -1), "shield-thickness"),
])
def test_bad_chronology_runs_are_refused(tmp_path: Path, small_valley: Path, extra: tuple,
                                         words: str) -> None:
    out = tmp_path / "bed.tif"
    args = ["glaciate", small_valley, out, "--ela-chronology", LR04, "--ela-present", 3000]
    if "--ela-glacial" not in extra and "--ela-lapse-rate" not in extra:
        args += ["--ela-glacial", 2000]
    assert_refused(run_cli(*args, *extra), out, words)


def test_glaciers_are_refused_backward_in_time(tmp_path: Path, small_valley: Path) -> None:
    out = tmp_path / "past.tif"
    assert_refused(run_cli("unerode", small_valley, out, "--process", "glacial"), out, "cannot run backward")
