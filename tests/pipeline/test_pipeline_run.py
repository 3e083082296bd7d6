"""`pipeline run`: end to end on a 32 × 32 DEM, dry runs, resume, failures and overwriting."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import rasterio
from tests.conftest import run_cli

from unerode_cli.pipeline.pipeline_run import StepFailed

SPEC = """\
version: 1
vars: {size: 32, steps: 2, dt: 1000}
steps:
  - {name: terrain, run: synth, args: [terrain.tif], options: {size: "${size}", seed: 3}}
  - name: eroded
    run: erode
    args: ["${steps.terrain.output}", eroded.tif]
    options: {dt: "${dt}", steps: "${steps}"}
  - name: picture
    run: preview
    args: ["${steps.eroded.output}", eroded.png]
  - name: area
    run: flow
    args: ["${steps.terrain.output}", area.tif]
    options: {what: area}
"""
OUTPUTS = ["terrain.tif", "eroded.tif", "eroded.png", "area.tif"]


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def snapshot(folder: Path) -> dict[str, tuple[int, str]]:
    """mtime (ns) and sha256 of each output that exists."""
    return {name: (p.stat().st_mtime_ns, sha256(p))
            for name in OUTPUTS if (p := folder / name).exists()}


def state(folder: Path) -> dict:
    return json.loads((folder / ".spec.state.json").read_text())


def make_spec(folder: Path, text: str = SPEC) -> Path:
    spec = folder / "spec.yaml"
    spec.write_text(text)
    return spec


def steps_said(stderr: str, word: str) -> list[str]:
    """Names of the steps whose progress line contains ``word``."""
    return [line.split("] ", 1)[1].split(":", 1)[0] for line in stderr.splitlines()
            if line.startswith("[") and word in line]


def test_a_spec_runs_end_to_end(tmp_path: Path) -> None:
    spec = make_spec(tmp_path)
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 0, result.stderr
    assert steps_said(result.stderr, "done in") == ["terrain", "eroded", "picture", "area"]
    assert "[2/4] eroded: unerode-cli erode terrain.tif eroded.tif --dt 1000 --steps 2" in result.stderr
    assert "pipeline finished: 4 step(s) ran, 0 skipped." in result.stderr
    with rasterio.open(tmp_path / "terrain.tif") as src:
        before = src.read(1).astype(float)
    with rasterio.open(tmp_path / "eroded.tif") as src:
        after = src.read(1).astype(float)
    assert before.shape == after.shape == (32, 32)
    assert np.abs(after - before).max() > 0.0          # the erode step changed the surface
    sidecar = json.loads((tmp_path / "eroded.tif.json").read_text())
    assert (sidecar["parameters"]["steps"], sidecar["parameters"]["dt_years"]) == (2, 1000.0)
    assert (tmp_path / "eroded.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    recorded = state(tmp_path)
    assert list(recorded["steps"]) == ["terrain", "eroded", "picture", "area"]
    for record in recorded["steps"].values():
        for name, digest in record["outputs"].items():
            assert sha256(tmp_path / name) == digest
    assert recorded["owned"] == sorted(OUTPUTS)
    assert not list(tmp_path.glob(".spec.state.*.part*"))   # the state was written atomically


def test_dry_run_runs_nothing(tmp_path: Path) -> None:
    spec = make_spec(tmp_path)
    result = run_cli("pipeline", "run", spec, "--dry-run", "--var", "dt=500")
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == [
        "run  terrain: unerode-cli synth terrain.tif --size 32 --seed 3",
        "run  eroded: unerode-cli erode terrain.tif eroded.tif --dt 500 --steps 2",
        "run  picture: unerode-cli preview eroded.tif eroded.png",
        "run  area: unerode-cli flow terrain.tif area.tif --what area",
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.yaml"]


def test_resume_skips_finished_steps_and_reruns_what_changed(tmp_path: Path) -> None:
    spec = make_spec(tmp_path)
    assert run_cli("pipeline", "run", spec).returncode == 0
    first = snapshot(tmp_path)

    result = run_cli("pipeline", "run", spec, "--resume")
    assert result.returncode == 0, result.stderr
    assert steps_said(result.stderr, "skipped") == ["terrain", "eroded", "picture", "area"]
    assert "pipeline finished: 0 step(s) ran, 4 skipped." in result.stderr
    assert snapshot(tmp_path) == first                  # nothing rewritten

    dry = run_cli("pipeline", "run", spec, "--dry-run", "--resume", "--var", "steps=3")
    assert [line.split(":")[0] for line in dry.stdout.splitlines()] == [
        "skip terrain", "run  eroded", "run  picture", "skip area"]
    assert "--steps 3 --overwrite" in dry.stdout
    assert snapshot(tmp_path) == first

    result = run_cli("pipeline", "run", spec, "--resume", "--var", "steps=3")
    assert result.returncode == 0, result.stderr
    assert steps_said(result.stderr, "skipped") == ["terrain", "area"]
    assert steps_said(result.stderr, "done in") == ["eroded", "picture"]
    after = snapshot(tmp_path)
    assert after["terrain.tif"] == first["terrain.tif"]
    assert after["area.tif"] == first["area.tif"]
    assert after["eroded.tif"][1] != first["eroded.tif"][1]
    assert after["eroded.png"][1] != first["eroded.png"][1]
    assert json.loads((tmp_path / "eroded.tif.json").read_text())["parameters"]["steps"] == 3

    # the same change again is now up to date; going back to 2 steps reruns eroded again
    again = run_cli("pipeline", "run", spec, "--resume", "--var", "steps=3")
    assert steps_said(again.stderr, "skipped") == ["terrain", "eroded", "picture", "area"]
    back = run_cli("pipeline", "run", spec, "--resume")
    assert steps_said(back.stderr, "done in") == ["eroded", "picture"]


def test_resume_reruns_a_step_whose_output_was_changed(tmp_path: Path) -> None:
    spec = make_spec(tmp_path, SPEC.split("  - name: eroded")[0])
    assert run_cli("pipeline", "run", spec).returncode == 0
    (tmp_path / "terrain.tif").write_bytes(b"damaged")
    result = run_cli("pipeline", "run", spec, "--resume")
    assert result.returncode == 0, result.stderr
    assert steps_said(result.stderr, "done in") == ["terrain"]
    assert "--overwrite" in result.stderr                 # its own output may be replaced
    with rasterio.open(tmp_path / "terrain.tif") as src:
        assert src.shape == (32, 32)


def test_a_failing_step_keeps_earlier_outputs_and_resume_continues(tmp_path: Path) -> None:
    # each value is valid on its own (checked before step 1); erode refuses their combination
    spec = make_spec(tmp_path, SPEC.replace('steps: "${steps}"', "duration: 1500"))
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 2                         # erode refused its input
    assert "error: --duration 1500 is not a whole number of --dt 1000 steps." in result.stderr
    assert ("error: step 'eroded' (erode) failed with exit code 2; earlier outputs and the state "
            "file are kept, so fix the cause and rerun with --resume.") in result.stderr
    assert steps_said(result.stderr, "done in") == ["terrain"]
    assert sorted(snapshot(tmp_path)) == ["terrain.tif"]
    assert list(state(tmp_path)["steps"]) == ["terrain"]
    first = snapshot(tmp_path)

    make_spec(tmp_path)                                   # fixed: dt 1000
    result = run_cli("pipeline", "run", spec, "--resume")
    assert result.returncode == 0, result.stderr
    assert steps_said(result.stderr, "skipped") == ["terrain"]
    assert steps_said(result.stderr, "done in") == ["eroded", "picture", "area"]
    assert snapshot(tmp_path)["terrain.tif"] == first["terrain.tif"]
    assert list(state(tmp_path)["steps"]) == ["terrain", "eroded", "picture", "area"]


def test_a_plain_rerun_runs_everything_and_replaces_its_own_outputs(tmp_path: Path) -> None:
    spec = make_spec(tmp_path, SPEC.split("  - name: eroded")[0])
    assert run_cli("pipeline", "run", spec).returncode == 0
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 0, result.stderr
    assert "[1/1] terrain: unerode-cli synth terrain.tif --size 32 --seed 3 --overwrite" in result.stderr


def test_an_output_the_pipeline_did_not_write_is_never_overwritten(tmp_path: Path) -> None:
    spec = make_spec(tmp_path)
    (tmp_path / "eroded.png").write_bytes(b"precious")
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "error: step 'picture' (outputs): eroded.png already exists and was not written by this "
        "pipeline, and a spec replaces only files it wrote, whatever its overwrite says; delete it "
        "or move it away first.")
    assert (tmp_path / "eroded.png").read_bytes() == b"precious"
    assert not (tmp_path / "terrain.tif").exists()        # refused before the first step
    assert not (tmp_path / ".spec.state.json").exists()

    # overwrite: true in the spec does not widen this (issue 45: a spec replaces only its own files)
    make_spec(tmp_path, SPEC.replace("args: [\"${steps.eroded.output}\", eroded.png]",
                                     "args: [\"${steps.eroded.output}\", eroded.png]\n"
                                     "    options: {overwrite: true}"))
    result = run_cli("pipeline", "run", spec)
    assert result.returncode == 2
    assert "a spec replaces only files it wrote" in result.stderr
    assert (tmp_path / "eroded.png").read_bytes() == b"precious"
    assert not (tmp_path / "terrain.tif").exists()


def test_a_damaged_state_file_is_refused(tmp_path: Path) -> None:
    spec = make_spec(tmp_path)
    (tmp_path / ".spec.state.json").write_text("{not json")
    result = run_cli("pipeline", "run", spec, "--dry-run")
    assert result.returncode == 2
    assert result.stderr.strip() == (f"error: state file {tmp_path.resolve() / '.spec.state.json'} "
                                     "is damaged; delete it to run every step again.")


def test_exit_codes_of_a_failed_step() -> None:
    assert [StepFailed("a", "erode", code).exit_code for code in (2, 1, 3, -9)] == [2, 1, 1, 1]
