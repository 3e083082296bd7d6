"""Uplift through time in climate-run: ``--uplift TABLE.csv`` of age_ka,U_m_per_y, or of
age_ka,factor times ``--uplift-map``, linear in age, its mean over each step used (so the surface
moves by exactly ∫U dt), refused when it does not cover the run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.cli import test_climate_run
from tests.cli.test_bad_input import assert_refused
from tests.cli.test_climate_run import LR04, read_timeline
from tests.conftest import run_cli, write_geotiff

from unerode_cli.climate.chronology import Series
from unerode_cli.climate.uplift import UpliftHistory
from unerode_cli.io.rasters import read_terrain

#: U (m/y) by age (ka), rows out of order, one inside the step 5 → 4 ka
TABLE = "# Têt-like uplift with a slowdown\nage_ka,U_m_per_y\n10,-1e-3\n0,1e-3\n4.5,3e-3\n"
INTEGRAL_M = 1000.0 * (4.5 * (1e-3 + 3e-3) / 2 + 5.5 * (3e-3 - 1e-3) / 2)  # 14.5 m over 0–10 ka
#: The fixture of a 30 × 16 ramp of 30 m cells, 4.5–23 m high, tilted towards the south edge.
ramp = test_climate_run.ramp


def table(path: Path, text: str = TABLE) -> Path:
    path.write_text(text)
    return path


def uplift_run(ramp: Path, out: Path, *args: object, span: tuple[float, float] = (10, 0)):
    """A fluvial run with K = 0 (no process moves the surface) and the south edge fixed."""
    return run_cli("climate-run", ramp, out, "--chronology", LR04, "--from", span[0], "--to", span[1],
                   "--dt", 1000, "--process", "fluvial", "--K", 0, "--outlets", "S",
                   "--dtype", "float64", *args)


def test_a_step_uses_the_mean_of_the_table_over_its_span():
    history = UpliftHistory(Series([0.0, 4.5, 10.0], [1e-3, 3e-3, -1e-3]))
    # no row inside the step: the value at its middle age (9.5 ka)
    assert history.over(10.0, 9.0) == pytest.approx(3e-3 - 4e-3 * 5.0 / 5.5, abs=1e-15)
    # a row inside (4.5 ka): the exact mean, not the value there (3e-3)
    u4, u5 = 1e-3 + 2e-3 * 4.0 / 4.5, 3e-3 - 4e-3 * 0.5 / 5.5
    assert history.over(5.0, 4.0) == pytest.approx(0.25 * (u4 + 3e-3) + 0.25 * (3e-3 + u5), abs=1e-15)
    assert sum(history.over(a + 1.0, a) for a in range(10)) * 1000.0 == pytest.approx(INTEGRAL_M, abs=1e-12)
    pattern = np.array([[1e-4, -2e-4]])
    np.testing.assert_allclose(UpliftHistory(Series([0.0, 10.0], [1.0, 2.0]), pattern).over(0.0, 10.0),
                               1.5 * pattern, rtol=1e-15)


@pytest.mark.parametrize(("span", "sign"), [((10, 0), 1.0), ((0, 10), -1.0)])
def test_the_surface_moves_by_the_integral_of_the_table(tmp_path: Path, ramp: Path, span, sign):
    """Forward 10 → 0 ka the surface rises by ∫U dt; backward 0 → 10 ka it goes down by as much."""
    out = tmp_path / "out.tif"
    result = uplift_run(ramp, out, "--uplift", table(tmp_path / "uplift.csv"), span=span)
    assert result.returncode == 0, result.stderr
    h0 = read_terrain(ramp).elevation.astype(np.float64)
    dh = read_terrain(out).elevation - h0
    np.testing.assert_allclose(dh[:-1], sign * INTEGRAL_M, atol=1e-6)  # the south edge is fixed
    rows = {round(float(r["age_ka"])): float(r["uplift_m_per_y"])
            for r in read_timeline(tmp_path / "out_timeline.csv")}
    middle = 9.5 if span == (10, 0) else 0.5
    end = 9 if span == (10, 0) else 1
    assert rows[end] == pytest.approx(float(np.interp(middle, [0, 4.5, 10], [1e-3, 3e-3, -1e-3])), abs=1e-15)
    assert sum(rows.values()) * 1000.0 == pytest.approx(INTEGRAL_M, abs=1e-9)


def test_a_factor_table_multiplies_the_uplift_map(tmp_path: Path, ramp: Path) -> None:
    cols = np.indices((30, 16))[1]
    pattern = np.where(cols < 8, 2.5e-4, -5e-5)  # mountains up, the valley subsiding
    write_geotiff(tmp_path / "u0.tif", pattern)
    factors = table(tmp_path / "f.csv", "age_ka,factor\n0,1\n10,0\n")  # mean factor 0.5
    out = tmp_path / "out.tif"
    result = uplift_run(ramp, out, "--uplift", factors, "--uplift-map", tmp_path / "u0.tif")
    assert result.returncode == 0, result.stderr
    dh = read_terrain(out).elevation - read_terrain(ramp).elevation.astype(np.float64)
    np.testing.assert_allclose(dh[:-1], 0.5 * 10_000.0 * pattern[:-1], atol=1e-6)


@pytest.mark.parametrize(("text", "extra", "mentions"), [
    ("age_ka,U_m_per_y\n0,1e-3\n5,1e-3\n", (), "covers 0–5 ka, not the whole run from 10 to 0 ka"),
    ("age_ka,factor\n0,1\n10,1\n", (), "holds a factor; give the raster it multiplies"),
    (TABLE, ("--uplift-map", "MAP"), "--uplift-map multiplies an uplift table of factor"),
    ("age_ka,U_m_per_y,factor\n0,1,1\n10,1,1\n", (), "exactly one value column"),
    ("age_ka,U_m_per_y\n0,1e-3\n0,2e-3\n10,0\n", (), "line 3: age 0 ka is given twice"),
    ("age_ka,U_m_per_y\n0,1e-3\n10,\n", (), "line 3: the required value 'U_m_per_y' is missing"),
    ("age_ka,U_m_per_y\n0,fast\n10,0\n", (), "line 2: U_m_per_y must be a number"),
    ("age_ka,U_m_per_y\n0,1e-3\n", (), "needs at least two rows"),
])
def test_bad_uplift_tables_are_refused(tmp_path: Path, ramp: Path, text, extra, mentions) -> None:
    write_geotiff(tmp_path / "u0.tif", np.full((30, 16), 1e-4))
    extra = tuple(tmp_path / "u0.tif" if e == "MAP" else e for e in extra)
    out = tmp_path / "out.tif"
    assert_refused(uplift_run(ramp, out, "--uplift", table(tmp_path / "u.csv", text), *extra), out, mentions)


def test_uplift_map_without_a_table_and_a_schedule_that_sets_u_are_refused(tmp_path: Path,
                                                                            ramp: Path) -> None:
    out = tmp_path / "out.tif"
    write_geotiff(tmp_path / "u0.tif", np.full((30, 16), 1e-4))
    assert_refused(uplift_run(ramp, out, "--uplift", "1e-4", "--uplift-map", tmp_path / "u0.tif"),
                   out, "--uplift-map needs --uplift TABLE.csv")
    schedule = tmp_path / "schedule.yaml"
    schedule.write_text("glacial: {U: 1.0e-4}\n")
    assert_refused(uplift_run(ramp, out, "--uplift", table(tmp_path / "u.csv"), "--params", schedule),
                   out, "sets the uplift per phase and --uplift is a table")


def test_resume_refuses_a_changed_uplift_table(tmp_path: Path, ramp: Path) -> None:
    out, uplift = tmp_path / "out.tif", table(tmp_path / "uplift.csv")
    first = uplift_run(ramp, out, "--uplift", uplift, "--max-steps", 3)
    assert first.returncode == 0, first.stderr
    table(uplift, TABLE.replace("10,-1e-3", "10,-2e-3"))
    assert_refused(uplift_run(ramp, out, "--uplift", uplift, "--resume"), None, "other inputs or options")
