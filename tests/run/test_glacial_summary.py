"""What a glacier run reports (issue 46 items 1 and 6): the timeline's record of each velocity
solve, the count of the solves that missed their tolerance in the summary and the sidecar, and
the rock removed and deposited by every process, which adds up to the change of the bed."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from tests.conftest import write_geotiff

from unerode_cli.glacier import coupled
from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.glacial import outputs

DX = 100.0


def _valley(ny: int = 20, nx: int = 30) -> np.ndarray:
    """A V valley draining east from a head above the ELA of 3000 m (floor 2300 + 1500·e^(−x/1200))."""
    y, x = np.mgrid[0:ny, 0:nx] * DX
    return 2300.0 + 1500.0 * np.exp(-x / 1200.0) + 0.25 * np.abs(y - (ny - 1) * DX / 2)


@pytest.fixture
def valley_dem(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "valley.tif", _valley().astype(np.float32),
                         Affine(DX, 0.0, 500000.0, 0.0, -DX, 5000000.0))


def _glaciate(monkeypatch, capsys, *args: object) -> str:
    """Run ``unerode-cli glaciate ARGS`` in this process; returns what it said (the summary goes to
    stderr, ``cli.common.say``), its exit status 0."""
    from unerode_cli.cli.app import main

    monkeypatch.setattr(sys, "argv", ["unerode-cli", "glaciate", *map(str, args)])
    with pytest.raises(SystemExit) as stop:
        main()
    captured = capsys.readouterr()
    assert stop.value.code in (0, None), captured.err
    return captured.out + captured.err


def _timeline(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_every_process_volume_adds_up_to_the_bed_change(tmp_path, valley_dem, monkeypatch, capsys) -> None:
    """All processes on (SIA ice flow, to keep it fast): removed − deposited = −Σ Δb·dx·dy, and
    the summary names every process; the timeline's flow columns stay empty without Blatter."""
    out, timeline = tmp_path / "bed.tif", tmp_path / "timeline.csv"
    text = _glaciate(monkeypatch, capsys, valley_dem, out, "--ela", 3000, "--duration", 300, "--dt", 20,
                     "--iceflow", "sia", "--sliding-C", 1e5, "--timeline", timeline)
    rows = _timeline(timeline)
    stats = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]
    assert {"flow_iterations", "flow_residual", "flow_converged"} <= set(rows[0])
    assert all(r["flow_iterations"] == r["flow_converged"] == "" for r in rows)
    assert stats["velocity_solves"] == 0 and stats["unconverged_solves"] == 0
    rock = stats["rock_volumes"]
    assert set(rock["removed_m3"]) == {"glacial", "hillslope", "debris", "fluvial"}
    change = read_terrain(out).elevation.astype(np.float64) - _valley()
    lost = -float(change.sum()) * DX * DX
    balance = rock["removed_total_m3"] - rock["deposited_total_m3"] - rock["uplifted_m3"]
    # the bed is written as float32: its rounding (~1e-4 m on 2–4 km) over 600 cells bounds the error
    assert balance == pytest.approx(lost, abs=600 * 2.5e-4 * DX * DX + 1e-6 * abs(lost))
    assert rock["removed_m3"]["glacial"] == pytest.approx(stats["eroded_volume_m3"]) and lost > 1e5
    assert rock["deposited_m3"]["hillslope"] > 0 and rock["removed_m3"]["fluvial"] > 0
    assert f"removed {rock['removed_total_m3']:.4g} m³ of rock (glacial" in text
    assert "debris flow" in text and "fluvial" in text and "deposited" in text
    assert "velocity solves" not in text


def test_solves_that_miss_the_tolerance_are_counted_and_said(tmp_path, valley_dem, monkeypatch,
                                                             capsys) -> None:
    """Solves held to 2 L-BFGS iterations end above the tolerance: the timeline marks them, the
    sidecar counts them and the summary says the run is not converged."""
    solve = coupled.flow_field

    def capped(*args, **kwargs):
        kwargs["max_iter"] = 2
        return solve(*args, **kwargs)

    monkeypatch.setattr(coupled, "flow_field", capped)
    out, timeline = tmp_path / "bed.tif", tmp_path / "timeline.csv"
    text = _glaciate(monkeypatch, capsys, valley_dem, out, "--ela", 3000, "--duration", 300, "--dt", 50,
                     "--timeline", timeline, "--no-hillslope", "--no-debris", "--no-fluvial")
    rows = _timeline(timeline)
    stats = json.loads((tmp_path / "bed.tif.json").read_text())["statistics"]
    residuals = np.array([float(r["flow_residual"]) for r in rows])
    met = np.array([int(r["flow_converged"]) for r in rows])
    np.testing.assert_array_equal(met, residuals <= coupled.FLOW_RTOL)
    assert sum(int(r["flow_iterations"]) for r in rows) == stats["flow_iterations"]
    assert stats["velocity_solves"] == len(rows) == stats["steps"]
    assert stats["flow_rtol"] == coupled.FLOW_RTOL
    missed = int(np.sum(met == 0))
    assert missed >= 2
    assert stats["unconverged_solves"] == missed
    assert stats["unconverged_fraction"] == pytest.approx(missed / len(rows))
    assert stats["max_flow_residual"] > coupled.FLOW_RTOL
    assert f"{len(rows)} velocity solves to a residual of {coupled.FLOW_RTOL:g}" in text
    assert f"{missed} missed it" in text
    assert f"warning: {missed} of {len(rows)} velocity solves" in text and "are not converged" in text


def test_the_warning_needs_more_than_one_percent() -> None:
    state = coupled.GlacierState(np.zeros((2, 2)), np.zeros((2, 2)))
    result = coupled.RunResult(state, [0.0], [0.0], solves=200, unconverged=2, max_residual=0.5)
    assert outputs.solves_warning(result, 0.01) == ""
    result.unconverged = 3
    assert outputs.solves_warning(result, 0.01).startswith("warning: 3 of 200 velocity solves (2%)")
    assert outputs.solves_warning(coupled.RunResult(state, [0.0], [0.0]), 0.01) == ""
