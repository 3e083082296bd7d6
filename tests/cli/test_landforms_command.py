"""`unerode-cli landforms`: the report of a synthetic glacial valley and of the Grindelwald DEM
(../shared/data), refused bad input and existing reports."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.cli.test_bad_input import assert_refused
from tests.cli.test_glaciate_real_dems import crop
from tests.conftest import SHARED_DATA, run_cli, write_geotiff

GRINDELWALD = SHARED_DATA / "dem" / "alps_grindelwald" / "dem.tif"
KEYS = {"dem", "before", "grid", "settings", "trunk", "u_shape", "hanging_valleys", "lakes", "hypsometry"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def glacial_valley() -> np.ndarray:
    """60 × 61 cells of 30 m: a parabolic trough along column 30 (z rises 5e-4 x² across,
    0.02 m/m to the south), a basin dug 8 m into its floor (rows 20–23), and a tributary valley
    from the east hanging 40 m above the trunk floor at row 40."""
    rows, cols = np.indices((60, 61), dtype=np.float64)
    x, y = (cols - 30) * 30.0, (rows - 40) * 30.0
    trunk = 500.0 + 0.6 * rows + 5e-4 * x**2
    trunk[20:24, 29:32] -= 8.0
    wall = np.sqrt(40.0 / 5e-4)  # where the tributary floor meets the trunk's wall (m east)
    tributary = 500.0 + 0.6 * 40 + 40.0 + 0.02 * (x - wall) + 1.0 * np.abs(y)
    return np.minimum(trunk, np.where(x > 0.0, tributary, np.inf))


@pytest.fixture
def valley_dem(tmp_path: Path) -> Path:
    return write_geotiff(tmp_path / "valley.tif", glacial_valley().astype(np.float32))


def report(folder: Path) -> dict:
    return json.loads((folder / "landforms.json").read_text())


def test_a_synthetic_glacial_valley(tmp_path: Path, valley_dem: Path) -> None:
    before = write_geotiff(tmp_path / "before.tif", (glacial_valley() + 0.5 * np.indices((60, 61))[1]
                                                     ).astype(np.float32))
    out = tmp_path / "report"
    result = run_cli("landforms", valley_dem, "--before", before, "--out", out, "--spacing", 300,
                     "--half-width", 600, "--reach", 400)
    assert result.returncode == 0, result.stderr
    assert "U-shape exponent b, median" in result.stdout and "lakes\t1" in result.stdout
    numbers = report(out)
    assert set(numbers) == KEYS
    assert numbers["u_shape"]["median_b"] == pytest.approx(2.0, abs=0.2)
    assert numbers["u_shape"]["sections_fitted"] >= 4
    assert numbers["lakes"]["count"] == 1
    assert numbers["lakes"]["area_m2"] == pytest.approx(12 * 900.0)
    assert numbers["hanging_valleys"]["hanging"] == 1
    (step,) = [j["step_m"] for j in numbers["hanging_valleys"]["junctions"] if j["hanging"]]
    assert step == pytest.approx(40.0, abs=8.0)
    hyps = numbers["hypsometry"]
    assert hyps["before"] is not None
    assert hyps["mean_shift_m"] == pytest.approx(-15.0, abs=0.01)  # before: + 0.5 m × column, mean 15 m
    assert (out / "landforms.png").read_bytes()[:8] == PNG_MAGIC


def test_an_existing_report_is_kept_without_overwrite(tmp_path: Path, valley_dem: Path) -> None:
    out = tmp_path / "report"
    out.mkdir()
    (out / "landforms.json").write_text("precious")
    assert_refused(run_cli("landforms", valley_dem, "--out", out), None, "--overwrite")
    assert (out / "landforms.json").read_text() == "precious"
    assert not (out / "landforms.png").exists()
    assert run_cli("landforms", valley_dem, "--out", out, "--overwrite", "--spacing", 250).returncode == 0
    assert report(out)["settings"]["spacing_m"] == 250.0


@pytest.mark.parametrize("case, mentions", [
    ("missing", "does not exist"),
    ("nodata", "no valid cell"),
    ("spacing", "--spacing"),
    ("out_is_file", "is a file"),
    ("outlets", "edge specification"),
])
def test_bad_input_is_refused(tmp_path: Path, valley_dem: Path, case: str, mentions: str) -> None:
    out = tmp_path / "report"
    dem, extra = valley_dem, []
    if case == "missing":
        dem = tmp_path / "nope.tif"
    elif case == "nodata":
        dem = write_geotiff(tmp_path / "void.tif", np.full((8, 8), -9999.0, np.float32), nodata=-9999.0)
    elif case == "spacing":
        extra = ["--spacing", "0"]
    elif case == "out_is_file":
        out.write_text("not a folder")
    elif case == "outlets":
        extra = ["--outlets", "up"]
    assert_refused(run_cli("landforms", dem, "--out", out, *extra), None, mentions)
    if case != "out_is_file":
        assert not out.exists()


@pytest.mark.skipif(not GRINDELWALD.exists(), reason="needs ../shared/data/dem")
def test_the_grindelwald_valley(tmp_path: Path) -> None:
    """The lower Grindelwald valley (Schwarze Lütschine, 140 × 220 cells of 46 m): a trunk of
    kilometres, cross-sections between V and U, a few lakes, and the hypsometry of a real
    mountain range (most of the area between 1000 and 3000 m)."""
    dem = crop(GRINDELWALD, slice(90, 230), slice(0, 220), tmp_path / "grindelwald.tif")
    out = tmp_path / "report"
    result = run_cli("landforms", dem, "--out", out)
    assert result.returncode == 0, result.stderr
    numbers = report(out)
    assert set(numbers) == KEYS
    assert 5000.0 < numbers["trunk"]["length_m"] < 15000.0
    assert numbers["u_shape"]["sections_fitted"] >= 10
    assert 0.8 < numbers["u_shape"]["median_b"] < 2.5
    assert all(0.2 <= s["b"] <= 8.0 and s["relief_m"] >= 30.0 for s in numbers["u_shape"]["sections"])
    assert all(abs(step) < 500.0 for step in numbers["hanging_valleys"]["steps_m"])
    assert numbers["lakes"]["count"] >= 1
    assert numbers["lakes"]["area_m2"] < 0.02 * 140 * 220 * 46.0**2
    assert 1000.0 < numbers["hypsometry"]["dem"]["mode_m"] < 3000.0
    assert (out / "landforms.png").read_bytes()[:8] == PNG_MAGIC
