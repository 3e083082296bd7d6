"""`glaciate --checkpoint-every/--max-steps/--resume`: a run stopped and continued ends where an
uninterrupted one does, bit for bit; checkpoints of other runs are refused."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from tests.cli.test_bad_input import assert_refused
from tests.cli.test_glaciate_command import DX, _transform, valley
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

from unerode_cli.io.checkpoints import checkpoint_path
from unerode_cli.io.rasters import read_terrain

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
pytestmark = pytest.mark.skipif(not LR04.exists(), reason="needs ../shared/data")
#: 300 y from 0.3 ka by 50 y, ramping up from 10 y: 8 steps, the drainage updated every 3; glaciers,
#: hill slopes, debris flow and rivers, and a snapshot every 100 y.
RUN = ("--ela-chronology", LR04, "--ela-present", 3000, "--ela-glacial", 2000, "--from", 0.3, "--to", 0,
       "--dt", 50, "--layers", 4, "--drainage-every", 3, "--snapshot-every", 100)


def _run(folder: Path, dem: Path, *extra) -> tuple[Path, object]:
    folder.mkdir(exist_ok=True)
    out = folder / "bed.tif"
    result = run_cli("glaciate", dem, out, *RUN, "--ice", folder / "ice.tif", "--timeline", folder / "t.csv",
                     *extra)
    return out, result


def test_a_stopped_and_resumed_run_ends_as_an_uninterrupted_one(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "valley.tif", valley(16, 24).astype(np.float32), _transform(DX))
    straight, result = _run(tmp_path / "straight", dem)
    assert result.returncode == 0, result.stderr
    assert not checkpoint_path(straight).exists()  # a finished run leaves none

    out, first = _run(tmp_path / "resumed", dem, "--max-steps", 3, "--checkpoint-every", 2)
    assert first.returncode == 0, first.stderr
    assert "stopped after step 3" in first.stderr + first.stdout
    assert checkpoint_path(out).exists() and not out.exists()
    again = run_cli("glaciate", dem, out, *RUN, "--ice", out.parent / "ice.tif", "--timeline",
                    out.parent / "t.csv", "--max-steps", 2, "--checkpoint-every", 2, "--resume")
    assert again.returncode == 0, again.stderr
    assert "resuming after step 3" in again.stderr + again.stdout
    _, last = _run(tmp_path / "resumed", dem, "--checkpoint-every", 2, "--resume")
    assert last.returncode == 0, last.stderr
    assert not checkpoint_path(out).exists()

    for name in ("bed.tif", "ice.tif", "ice_001.tif", "ice_002.tif", "ice_003.tif"):
        a = read_terrain(tmp_path / "straight" / name).elevation
        b = read_terrain(out.parent / name).elevation
        np.testing.assert_array_equal(a, b, err_msg=name)
    rows = [list(csv.DictReader((tmp_path / d / "t.csv").open())) for d in ("straight", "resumed")]
    assert len(rows[0]) == len(rows[1]) >= 8
    for a, b in zip(*rows, strict=True):
        assert a["time_y"] == b["time_y"] and a["ice_volume_m3"] == b["ice_volume_m3"]
    stats = [json.loads((tmp_path / d / "bed.tif.json").read_text())["statistics"]
             for d in ("straight", "resumed")]
    for key in ("steps", "eroded_volume_m3", "ice_volume_series", "rejected_steps", "energy_evaluations"):
        assert stats[0][key] == stats[1][key], key
    assert [Path(p).name for p in stats[1]["snapshots"]] == ["ice_001.tif", "ice_002.tif", "ice_003.tif"]
    assert stats[0]["ice_free_removed_m3"] == stats[1]["ice_free_removed_m3"]


def test_a_checkpoint_is_continued_or_replaced_never_silently(tmp_path: Path) -> None:
    dem = write_geotiff(tmp_path / "valley.tif", valley(16, 24).astype(np.float32), _transform(DX))
    out, first = _run(tmp_path / "run", dem, "--max-steps", 2)
    assert first.returncode == 0, first.stderr
    refused = run_cli("glaciate", dem, out, *RUN, "--ice", out.parent / "ice.tif", "--timeline",
                      out.parent / "t.csv")
    assert_refused(refused, mentions="pass --resume to continue it")
    other = run_cli("glaciate", dem, out, *RUN[:-2], "--snapshot-every", 150, "--ice", out.parent / "ice.tif",
                    "--timeline", out.parent / "t.csv", "--resume")
    assert_refused(other, mentions="belongs to a run with other inputs or options")
