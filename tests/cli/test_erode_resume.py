"""erode and unerode on the shared stepping loop: --max-steps stops with a checkpoint, --resume
continues bit for bit (elevation, snapshots, mass budget), a finished run removes its
checkpoint, and a checkpoint of another run is refused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.conftest import SAMPLE_DEMS, run_cli

DEM = SAMPLE_DEMS / "valley_utm32n_30m.tif"
OPTIONS = ["--process", "fluvial,thermal", "--dt", "500", "--steps", "6", "--K", "2e-5",
           "--snapshot-every", "1000", "--checkpoint-every", "2"]


def pixels(path: Path) -> np.ndarray:
    with rasterio.open(path) as src:
        return src.read(1)


@pytest.mark.parametrize(("command", "scheme"), [("erode", []), ("erode", ["--scheme", "implicit"]),
                                               ("unerode", [])])
def test_a_stopped_run_resumes_bit_for_bit(tmp_path: Path, command: str, scheme: list[str]) -> None:
    # the implicit scheme starts each step's deposition iteration from the last step's rates,
    # which the checkpoint keeps
    options = [*OPTIONS, *scheme]
    full, part = tmp_path / "full.tif", tmp_path / "part.tif"
    assert run_cli(command, DEM, full, *options).returncode == 0
    stopped = run_cli(command, DEM, part, *options, "--max-steps", "3")
    assert stopped.returncode == 0 and "stopped after step 3 of 6" in stopped.stderr
    checkpoint = tmp_path / ".part.tif.checkpoint.npz"
    assert checkpoint.exists() and not part.exists()
    refused = run_cli(command, DEM, part, *options)
    assert refused.returncode == 2 and "--resume" in refused.stderr
    resumed = run_cli(command, DEM, part, *options, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming after step 3 of 6" in resumed.stderr
    assert not checkpoint.exists()
    for name in ("", "_001", "_002", "_003"):
        assert np.array_equal(pixels(tmp_path / f"full{name}.tif"), pixels(tmp_path / f"part{name}.tif"),
                              equal_nan=True)
    budget = [json.loads((tmp_path / f"{n}.tif.json").read_text())["statistics"]["mass_budget_m3"]
              for n in ("full", "part")]
    assert budget[0] == budget[1]


def test_a_checkpoint_of_another_run_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "out.tif"
    assert run_cli("erode", DEM, out, *OPTIONS, "--max-steps", "2").returncode == 0
    other = [o if o != "2e-5" else "3e-5" for o in OPTIONS]
    result = run_cli("erode", DEM, out, *other, "--resume")
    assert result.returncode == 2
    assert "belongs to a run with other inputs or options" in result.stderr
