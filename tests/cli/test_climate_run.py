"""climate-run as a user runs it: real chronology, sea-level boundaries, snapshots, resume."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.cli.test_bad_input import assert_refused
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

from unerode_cli.io.rasters import read_terrain
from unerode_cli.jobs.climate_run.job import ClimateJob
from unerode_cli.jobs.climate_run.plan import plan
from unerode_cli.jobs.climate_run.steps import step_values

LR04 = SHARED_DATA / "lr04" / "LR04stack.txt"
SPRATT = SHARED_DATA / "sealevel" / "spratt2016.txt"


@pytest.fixture
def ramp(tmp_path: Path) -> Path:
    """30 × 16 cells of 30 m, tilted towards the south edge (0.02), with small bumps."""
    rows, cols = np.indices((30, 16))
    z = 5.0 + 0.6 * (29 - rows) + 0.5 * np.sin(cols * 0.9) * np.cos(rows * 0.7)
    return write_geotiff(tmp_path / "ramp.tif", z.astype(np.float32))


def sea_fall_table(path: Path, fall_m: float) -> Path:
    """A sea-level curve (age ka, m): 0 m before 20 ka, falling linearly to −fall at 16 ka
    (10–40 ka only: a table that does not reach the present is not re-anchored to 0 m)."""
    ages = np.arange(10.0, 41.0, 1.0)
    sea = np.where(ages >= 20, 0.0, -fall_m * np.clip((20 - ages) / 4, 0, 1))
    lines = [f"{a:g} {s:g}\n" for a, s in zip(ages, sea, strict=True)]
    path.write_text("# age_ka sea_level_m\n" + "".join(lines))
    return path


def read_timeline(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_backward_run_along_the_real_chronology(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "past.tif"
    result = run_cli("climate-run", ramp, out, "--chronology", LR04, "--sea-level", SPRATT,
                     "--from", 0, "--to", 24, "--dt", 1000, "--snapshots", "12,20",
                     "--outlets", "S", "--K", "1e-4", "--preview", tmp_path / "past.png")
    assert result.returncode == 0, result.stderr
    rows = read_timeline(tmp_path / "past_timeline.csv")
    assert len(rows) == 24
    by_age = {round(float(r["age_ka"])): r for r in rows}
    assert by_age[2]["phase"] == "interglacial"
    assert by_age[21]["phase"] == "glacial"
    assert by_age[21]["k_th"] == "0.008" and by_age[2]["k_th"] == "0.002"
    assert float(by_age[20]["sea_level_m"]) == pytest.approx(-120.0, abs=20.0)
    for name in ("eroded_m3", "deposited_m3", "mean_abs_dh_m", "max_abs_dh_m", "precipitation"):
        assert name in rows[0]
    with rasterio.open(tmp_path / "past_12ka.tif") as src:
        tags = src.tags()
    assert float(tags["UNERODE_AGE_KA"]) == pytest.approx(12.0)
    assert tags["UNERODE_PHASE"] in {"end-of-glacial", "interglacial", "glacial"}
    assert float(tags["UNERODE_SEA_LEVEL_M"]) == pytest.approx(float(by_age[12]["sea_level_m"]))
    assert (tmp_path / "past_chronology.png").stat().st_size > 20_000
    assert (tmp_path / "past.png").exists()
    assert not list(tmp_path.glob(".past.tif.checkpoint*"))


def test_boundary_follows_sea_level_and_incision_starts_at_the_outlet(tmp_path: Path,
                                                                      ramp: Path) -> None:
    fallen, steady = tmp_path / "fallen.tif", tmp_path / "steady.tif"
    same_climate = tmp_path / "schedule.yaml"  # the phases differ; only the base level should
    same_climate.write_text("".join(f"{phase}: {{precipitation: 1.0}}\n"
                                    for phase in ("glacial", "end-of-glacial", "interglacial")))
    common = ("--chronology-kind", "sea-level", "--from", 20, "--to", 12, "--dt", 500,
              "--outlets", "S", "--coast", "S", "--process", "fluvial", "--K", "2e-4", "--K-d", "0",
              "--no-sea-outlets", "--params", same_climate)
    for out, fall in ((fallen, 120.0), (steady, 0.0)):
        table = sea_fall_table(tmp_path / f"sea{fall:g}.txt", fall)
        result = run_cli("climate-run", ramp, out, "--chronology", table, *common)
        assert result.returncode == 0, result.stderr
    h0 = read_terrain(ramp).elevation
    h_fall, h_steady = read_terrain(fallen).elevation, read_terrain(steady).elevation
    # the south edge (the boundary nodes) followed the 120 m fall exactly (float32 output)
    np.testing.assert_allclose(h_fall[-1], h0[-1] - 120.0, atol=1e-4)
    np.testing.assert_allclose(h_steady[-1], h0[-1], atol=1e-4)
    incision = h_steady - h_fall
    assert incision[-2].mean() > 1.0  # next to the outlet: incised by the base-level fall
    assert np.abs(incision[:5]).max() < 1e-3  # far upstream: not reached yet
    rows = read_timeline(tmp_path / "fallen_timeline.csv")
    assert float(rows[-1]["sea_level_m"]) == pytest.approx(-120.0)


def test_resume_after_an_interruption_is_bit_identical(tmp_path: Path, ramp: Path) -> None:
    args = ("--chronology", LR04, "--from", 0, "--to", 10, "--dt", 1000, "--outlets", "S",
            "--process", "fluvial,thermal", "--K", "1e-4", "--checkpoint-every", 2)
    whole, parts = tmp_path / "whole.tif", tmp_path / "parts.tif"
    assert run_cli("climate-run", ramp, whole, *args).returncode == 0
    first = run_cli("climate-run", ramp, parts, *args, "--max-steps", 3)
    assert first.returncode == 0, first.stderr
    assert "resume" in first.stderr
    assert not parts.exists() and (tmp_path / ".parts.tif.checkpoint.npz").exists()
    second = run_cli("climate-run", ramp, parts, *args, "--resume")
    assert second.returncode == 0, second.stderr
    a, b = read_terrain(whole).elevation, read_terrain(parts).elevation
    assert np.array_equal(a, b)
    assert (tmp_path / "whole_timeline.csv").read_text() == (tmp_path / "parts_timeline.csv").read_text()


def test_bad_climate_runs_are_refused(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "p.tif"
    assert_refused(run_cli("climate-run", ramp, out, "--chronology", LR04, "--to", 10,
                           "--snapshots", "2.5"), out, "snapshot age 2.5")
    assert_refused(run_cli("climate-run", ramp, out, "--chronology", LR04, "--from", 0,
                           "--to", 10, "--direction", "forward"), out, "runs backward")
    assert_refused(run_cli("climate-run", ramp, out, "--chronology", SPRATT,
                           "--chronology-kind", "sea-level", "--to", 900), out, "798")
    assert_refused(run_cli("climate-run", ramp, out, "--chronology", tmp_path / "none.txt"),
                   out, "none.txt")


def test_parameter_rasters_survive_a_climate_run_scaled_per_phase(tmp_path: Path, ramp: Path) -> None:
    """A K_th map is 4 × itself in glacial steps (0.008 / 0.002) and as given in interglacials;
    K and U maps, which the default schedule does not set, stay as given."""
    cols = np.indices((30, 16))[1]
    maps = {"k_th": 0.002 * np.where(cols < 8, 1.0, 2.0), "k": np.where(cols < 8, 1e-5, 3e-5),
            "uplift": np.where(cols < 8, 1e-4, -5e-5)}
    paths = {name: str(write_geotiff(tmp_path / f"{name}.tif", value)) for name, value in maps.items()}
    prepared = plan(ClimateJob(source=ramp, output=tmp_path / "p.tif", chronology=LR04,
                               sea_level_file=SPRATT, from_ka=0, to_ka=24, outlets="S",
                               process="fluvial,thermal", **paths))
    phases = list(prepared.forcing.phase)
    glacial, interglacial = phases.index("glacial"), phases.index("interglacial")
    values, row = step_values(prepared, glacial)
    np.testing.assert_allclose(values["k_th"], 4.0 * maps["k_th"], rtol=1e-12)
    np.testing.assert_array_equal(values["k"], maps["k"])
    np.testing.assert_array_equal(values["uplift"], maps["uplift"])
    assert row["k_th"] == 0.008 and row["uplift_m_per_y"] == pytest.approx(2.5e-5)
    np.testing.assert_allclose(step_values(prepared, interglacial)[0]["k_th"], maps["k_th"], rtol=1e-12)
