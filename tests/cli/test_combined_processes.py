"""Several processes in one run (operator splitting), parameters from a YAML file, refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff

from unerode_cli.io.rasters import read_terrain
from unerode_cli.synthetic import synthesize


@pytest.fixture
def mountain(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "m.tif", synthesize("mountain", (40, 36), 600.0, 4)
                         .astype(np.float32))


def test_every_process_runs_forward_in_one_command(tmp_path: Path, mountain: Path) -> None:
    out = tmp_path / "e.tif"
    result = run_cli("erode", mountain, out, "--process", "fluvial,thermal,hillslope,debris",
                     "--dt", 500, "--steps", 3, "--K", "2e-5", "--k-th", "0.008",
                     "--uplift", "0.001")
    assert result.returncode == 0, result.stderr
    stats = json.loads((tmp_path / "e.tif.json").read_text())["statistics"]
    budgets = stats["mass_budget_m3"]
    assert list(budgets) == ["fluvial", "thermal", "hillslope", "debris"]
    for name, b in budgets.items():
        assert b["eroded"] > 0, name
        assert abs(b["residual"]) <= 1e-9 * b["eroded"], name
    # uplift is applied once per step, whatever the number of processes that declare it
    before, after = read_terrain(mountain).elevation, read_terrain(out).elevation
    processes_only = sum(b["deposited"] - b["eroded"] for b in budgets.values())
    uplifted = (after - before).sum() * 900.0 - processes_only
    interior = (40 - 2) * (36 - 2) * 900.0
    assert uplifted == pytest.approx(0.001 * 1500.0 * interior, rel=1e-3)


def test_parameter_file_with_groups_and_command_line_override(tmp_path: Path, mountain: Path) -> None:
    spec = tmp_path / "params.yaml"
    spec.write_text("uplift: 0\nfluvial:\n  K: 3.0e-5\n  K_d: 0.5\nthermal:\n  talus_angle: 33\n"
                    "  k_th: 0.004\n")
    out = tmp_path / "e.tif"
    result = run_cli("erode", mountain, out, "--process", "fluvial,thermal", "--dt", 500,
                     "--steps", 2, "--params", spec, "--k-th", "0.006")
    assert result.returncode == 0, result.stderr
    parameters = json.loads((tmp_path / "e.tif.json").read_text())["parameters"]
    assert parameters["k"] == "3e-05"
    assert parameters["k_d"] == "0.5"
    assert parameters["talus_angle"] == "33"
    assert parameters["k_th"] == "0.006"  # the command line wins


def test_parameter_file_errors_are_one_sentence(tmp_path: Path, mountain: Path) -> None:
    out = tmp_path / "e.tif"
    bad = tmp_path / "bad.yaml"
    bad.write_text("fluvial:\n  k_th: 0.1\n")
    assert_refused(run_cli("erode", mountain, out, "--process", "fluvial,thermal", "--steps", 1,
                           "--params", bad), out, "not a parameter of process fluvial")
    bad.write_text("K: [1, 2\n")
    assert_refused(run_cli("erode", mountain, out, "--steps", 1, "--params", bad), out,
                   "not valid yaml")
    bad.write_text("talus_angle: 30\n")  # a thermal parameter in a fluvial-only run
    assert_refused(run_cli("erode", mountain, out, "--steps", 1, "--params", bad), out,
                   "not a parameter")


@pytest.mark.parametrize("process,mentions", [
    ("hillslope", "ill-posed"),
    ("fluvial,debris", "debris flow cannot run backward"),
    ("thermal-ca", "no backward form"),
])
def test_unerode_refuses_processes_without_a_backward_form(tmp_path: Path, mountain: Path,
                                                           process: str, mentions: str) -> None:
    out = tmp_path / "u.tif"
    assert_refused(run_cli("unerode", mountain, out, "--process", process, "--steps", 1), out,
                   mentions)


def test_unknown_process_and_constraint_are_refused(tmp_path: Path, mountain: Path) -> None:
    out = tmp_path / "u.tif"
    assert_refused(run_cli("erode", mountain, out, "--process", "fluvial,lava", "--steps", 1),
                   out, "unknown process 'lava'")
    assert_refused(run_cli("unerode", mountain, out, "--process", "thermal", "--steps", 1,
                           "--thermal-constraints", "slope,walls"), out, "walls")


def test_thermal_unerosion_without_constraints_runs(tmp_path: Path, mountain: Path) -> None:
    on, off = tmp_path / "on.tif", tmp_path / "off.tif"
    for out, constraints in ((on, "slope,convexity,rate"), (off, "none")):
        result = run_cli("unerode", mountain, out, "--process", "thermal", "--dt", 500,
                         "--steps", 2, "--k-th", "8", "--thermal-constraints", constraints)
        assert result.returncode == 0, result.stderr
    h0 = read_terrain(mountain).elevation
    # without constraints, un-deposition digs deeper below the input
    assert (read_terrain(off).elevation - h0).min() < (read_terrain(on).elevation - h0).min()
