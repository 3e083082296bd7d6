"""The example pipelines in pipelines/ stay valid: every step, option and input checks out."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

PIPELINES = Path(__file__).resolve().parents[2] / "pipelines"


@pytest.mark.skipif(not (SHARED_DATA / "lr04").is_dir(), reason="needs ../shared/data")
def test_last_glacial_cycle_spec_validates() -> None:
    (PIPELINES / "runs" / "last_glacial_cycle").mkdir(parents=True, exist_ok=True)
    result = run_cli("pipeline", "run", PIPELINES / "last_glacial_cycle.yaml", "--dry-run")
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stdout.splitlines() if line.strip()]
    assert [line.split(":")[0].split()[-1] for line in lines] == ["past", "lgm-preview",
                                                                  "lgm-rivers"]
    assert "--to 120" in lines[0] and "--snapshots 12,20,60,120" in lines[0]


@pytest.mark.skipif(not (SHARED_DATA / "lr04").is_dir(), reason="needs ../shared/data")
@pytest.mark.parametrize(("spec", "last"), [("tautavel_terraces", "--observations"),
                                            ("tet_incision", "--incision")])
def test_case_study_specs_validate(spec: str, last: str) -> None:
    (PIPELINES / "runs" / spec).mkdir(parents=True, exist_ok=True)
    result = run_cli("pipeline", "run", PIPELINES / f"{spec}.yaml", "--dry-run")
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stdout.splitlines() if line.startswith("run")]
    assert [line.split(":")[0].split()[-1] for line in lines] == ["past", "compare"]
    assert "compare-terraces" in lines[1] and last in lines[1] and "--auto-river" in lines[1]


@pytest.mark.skipif(not (SHARED_DATA / "lr04").is_dir(), reason="needs ../shared/data")
def test_tautavel_pipeline_runs_on_any_dem(tmp_path: Path) -> None:
    """The whole case study on a small V-valley given as a variable: climate-run back to
    814 ka, then compare-terraces against the three dated terraces."""
    rows, cols = np.mgrid[0:24, 0:20].astype(float)
    valley = 2.0 + 4.0 * rows + 3.0 * np.abs(cols - 10.0)   # drains north to the sea
    dem = write_geotiff(tmp_path / "valley.tif", valley.astype(np.float32))
    spec = tmp_path / "tautavel.yaml"
    text = (PIPELINES / "tautavel_terraces.yaml").read_text()
    spec.write_text(text.replace("workdir: runs/tautavel_terraces", f"workdir: {tmp_path / 'run'}")
                    .replace("../../observations", str(PIPELINES / "observations"))
                    .replace("../../../../shared/data", str(SHARED_DATA)))
    (tmp_path / "run").mkdir()
    result = run_cli("pipeline", "run", spec, "--var", f"dem={dem}", "--var", "dt=2000")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "run" / "report" / "summary.json").read_text())
    assert [row["age_ka"] for row in summary["terraces"]["rows"]] == [12.0, 60.0, 814.0]
    assert [s["age_ka"] for s in summary["snapshots"]] == [12.0, 60.0, 120.0, 240.0, 420.0, 600.0, 814.0]
    assert np.isfinite(summary["terraces"]["rmse_m"])
    assert (tmp_path / "run" / "report" / "profiles.png").stat().st_size > 20_000


@pytest.mark.skipif(not (SHARED_DATA / "lr04").is_dir(), reason="needs ../shared/data")
def test_nested_spec_validates() -> None:
    (PIPELINES / "runs" / "nested_bigtujunga").mkdir(parents=True, exist_ok=True)
    result = run_cli("pipeline", "run", PIPELINES / "nested_bigtujunga.yaml", "--dry-run")
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stdout.splitlines() if line.startswith("run")]
    assert [line.split(":")[0].split()[-1] for line in lines] == [
        "coarse_dem", "window_dem", "coarse", "nested", "alone", "difference"]
    assert "--write-fluxes" in lines[2] and "--inflow-from coarse_past.tif" in lines[3]
    assert "--inflow-from" not in lines[4]


@pytest.mark.skipif(not (SHARED_DATA / "lr04").is_dir(), reason="needs ../shared/data")
def test_tet_pipeline_runs_thermal_and_fluvial_over_5_ma(tmp_path: Path) -> None:
    """000 §6.3.2 with the paper's combination (thermal then fluvial, Table 1 schedule) over its
    whole span, on a 64 × 64 crop of the sample coast: no runaway, every step bounded."""
    from unerode_cli.io.rasters import read_terrain

    sample = read_terrain(PIPELINES.parent / "sample_dems" / "eroded_utm32n_30m.tif")
    dem = write_geotiff(tmp_path / "coast.tif", sample.elevation[-64:, 96:160].astype(np.float32))
    spec = tmp_path / "tet.yaml"
    text = (PIPELINES / "tet_incision.yaml").read_text()
    spec.write_text(text.replace("workdir: runs/tet_incision", f"workdir: {tmp_path / 'run'}")
                    .replace("../../observations", str(PIPELINES / "observations"))
                    .replace("../../../../shared/data", str(SHARED_DATA)))
    result = run_cli("pipeline", "run", spec, "--var", f"dem={dem}")
    assert result.returncode == 0, result.stderr
    assert "--process thermal,fluvial" in result.stderr + result.stdout
    timeline = np.genfromtxt(tmp_path / "run" / "tet_past_timeline.csv", delimiter=",", names=True,
                             dtype=None, encoding="utf-8")
    assert timeline["age_ka"][-1] == pytest.approx(5000.0)
    assert float(np.max(timeline["max_abs_dh_m"])) < 25.0   # m per 2 ky step
    summary = json.loads((tmp_path / "run" / "report" / "summary.json").read_text())
    rates = [row["simulated_mm_per_ka"] for row in summary["incision"]["periods"]]
    assert len(rates) == 3 and all(np.isfinite(rates))


@pytest.mark.skipif(not (SHARED_DATA / "lr04").is_dir(), reason="needs ../shared/data")
@pytest.mark.parametrize(("spec", "steps", "glacier_steps"), [
    ("glacial_fig6", ["relief", "uplift", "fluvial", "cooling", "warming", "landforms"],
     ["cooling", "warming"]),
    ("grindelwald_glacial_cycle", ["dem", "cycle", "landforms"], ["cycle"])])
def test_glacial_case_study_specs_validate(spec: str, steps: list[str], glacier_steps: list[str]) -> None:
    (PIPELINES / "runs" / spec).mkdir(parents=True, exist_ok=True)
    result = run_cli("pipeline", "run", PIPELINES / f"{spec}.yaml", "--dry-run")
    assert result.returncode == 0, result.stderr
    lines = [line for line in result.stdout.splitlines() if line.startswith("run")]
    assert [line.split(":")[0].split()[-1] for line in lines] == steps
    assert [line.split(":")[0].split()[-1] for line in lines if "unerode-cli glaciate " in line] \
        == glacier_steps
