"""sandstone on the shared stepping loop: --max-steps stops with its checkpoint (OUT_DIR/state.npz)
and the outputs of the frames done, --resume continues bit for bit (particles, top heightfield,
the frames' counts), a finished run removes its checkpoint, and a checkpoint of another run is
refused."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
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
          "max_stress_mpa", "mpm_substeps", "mpm_residual", "eroded_fluvial", "discharge_max_m3y", "fallen")


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
