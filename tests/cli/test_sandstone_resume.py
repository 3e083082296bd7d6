"""sandstone on the shared stepping loop: --max-steps stops with its checkpoint (OUT_DIR/state.npz,
compressed, without what a frame recomputes first) and the outputs of the frames done, --resume
continues bit for bit (particles, top heightfield, the frames' counts) and reports the whole run,
a finished run removes its checkpoint, and a checkpoint of another run is refused."""

from __future__ import annotations

import csv
import json
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest
from tests.conftest import run_cli

from unerode_cli.io.particle_ply import read_particle_ply
from unerode_cli.io.rasters import read_terrain

SCENE = """
domain: {size: [16, 10, 12]}
particles: 2500
shape:
  difference:
    - box: {min: [3, 3, 0], max: [13, 7, 9]}
    - cylinder: {base: [8, 2, 0], radius: 2, height: 8, axis: y}
layers:
  - {top: 4, k_w: 2e-4, interlocking: 1.5e6, k_a: 0.02, k_d: 1.0}
  - {k_w: 1e-4, interlocking: 3e6, k_a: 0.01, k_d: 0.5}
wind: {azimuth: 200, speed: 10}
"""
OPTIONS = ("--frames", "5", "--seed", "7", "--threads", "1", "--checkpoint-every", "2",
           "--substeps", "20", "--settle-substeps", "400")
#: Columns of frames.csv that do not time anything.
COUNTS = ("frame", "particles", "eroded", "deposited", "exported", "surface", "interlocked_share",
          "max_stress_mpa", "mpm_substeps", "mpm_residual", "mpm_coarse_cost", "eroded_fluvial",
          "discharge_max_m3y", "fallen")


def _scene(tmp_path: Path) -> Path:
    path = tmp_path / "scene.yaml"
    path.write_text(SCENE)
    return path


def _counts(out: Path) -> list[dict[str, str]]:
    with open(out / "frames.csv", newline="") as handle:
        return [{k: r[k] for k in COUNTS} for r in csv.DictReader(handle)]


def test_a_stopped_run_resumes_bit_for_bit(tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    whole, part = tmp_path / "whole", tmp_path / "part"
    result = run_cli("sandstone", scene, whole, *OPTIONS)
    assert result.returncode == 0, result.stderr
    assert not (whole / "state.npz").exists()          # a finished run removes its checkpoint

    stopped = run_cli("sandstone", scene, part, *OPTIONS, "--max-steps", "3")
    assert stopped.returncode == 0, stopped.stderr
    assert "3 of 5 frames (stopped early" in stopped.stderr and "--resume" in stopped.stderr
    assert (part / "state.npz").exists() and len(_counts(part)) == 3
    refused = run_cli("sandstone", scene, part, *OPTIONS)
    assert refused.returncode == 2 and "--resume" in refused.stderr

    again = run_cli("sandstone", scene, part, *OPTIONS, "--resume", "--max-steps", "1")
    assert again.returncode == 0, again.stderr
    assert "resuming after step 3 of 5" in again.stderr and len(_counts(part)) == 4
    resumed = run_cli("sandstone", scene, part, *OPTIONS, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming after step 4 of 5" in resumed.stderr
    assert not (part / "state.npz").exists()

    assert (part / "particles.ply").read_bytes() == (whole / "particles.ply").read_bytes()
    props = [read_particle_ply(out / "particles.ply")[0] for out in (whole, part)]
    assert props[0].keys() == props[1].keys()
    assert all(np.array_equal(props[0][k], props[1][k]) for k in props[0])
    tops = [read_terrain(out / "top.tif").elevation for out in (whole, part)]
    assert np.array_equal(tops[0], tops[1], equal_nan=True)
    assert _counts(part) == _counts(whole) and len(_counts(whole)) == 5


def test_a_checkpoint_of_another_run_is_refused(tmp_path: Path) -> None:
    scene, out = _scene(tmp_path), tmp_path / "out"
    assert run_cli("sandstone", scene, out, *OPTIONS, "--max-steps", "1").returncode == 0
    state = (out / "state.npz").read_bytes()
    other = run_cli("sandstone", scene, out, *OPTIONS, "--wind-speed", "12", "--resume")
    assert other.returncode == 2
    assert "other parameters or another seed" in other.stderr
    assert (out / "state.npz").read_bytes() == state


def test_a_resumed_run_reports_the_whole_run(tmp_path: Path) -> None:
    """After --resume the progress counts on from the frames done, and the summary and run.json
    count every frame of the run (the rows restored with the state and the new ones: frames.csv's
    sums) and the wall time of both invocations."""
    scene, out = _scene(tmp_path), tmp_path / "out"
    options = ("--frames", "2", *OPTIONS[2:])
    stopped = run_cli("sandstone", scene, out, *options, "--max-steps", "1")
    assert stopped.returncode == 0, stopped.stderr
    first = float(re.search(r"in ([\d.]+) s;", stopped.stderr).group(1))
    with zipfile.ZipFile(out / "state.npz") as state:
        names = set(state.namelist())
        assert all(info.compress_type == zipfile.ZIP_DEFLATED for info in state.infolist())
    assert "array.particle_deformation.npy" in names and "array.particle_stress.npy" not in names
    resumed = run_cli("sandstone", scene, out, *options, "--resume", "-v")
    assert resumed.returncode == 0, resumed.stderr
    assert "sandstone 2/2: " in resumed.stderr and "sandstone 1/" not in resumed.stderr   # counts on
    said = re.search(r"after 2 frames \(([\d,]+) eroded, ([\d,]+) exported; .*\) in ([\d.]+) s "
                     r"\(([\d.]+) s in this invocation\)", resumed.stderr)
    assert said, resumed.stderr
    with open(out / "frames.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["frame"] for r in rows] == ["1", "2"]
    eroded, exported = (sum(int(r[k]) for r in rows) for k in ("eroded", "exported"))
    assert (int(said.group(1).replace(",", "")), int(said.group(2).replace(",", ""))) == (eroded, exported)
    whole, this = float(said.group(3)), float(said.group(4))
    assert this <= whole <= first + this + 0.1 and whole - this > 0.0
    statistics = json.loads((out / "run.json").read_text())["statistics"]
    assert (statistics["frames"], statistics["eroded"], statistics["exported"]) == (2, eroded, exported)
    assert statistics["wall_time_s"] == pytest.approx(whole, abs=0.051)
