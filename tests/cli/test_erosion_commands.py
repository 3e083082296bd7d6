"""flow, erode and unerode as a user runs them: outputs, sidecars, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from affine import Affine
from tests.cli.test_bad_input import assert_refused
from tests.conftest import run_cli, write_geotiff

from unerode_cli.io.rasters import read_terrain


@pytest.fixture
def ramp(tmp_path: Path) -> Path:
    """A 24 × 20 surface tilted towards the south edge with small bumps (30 m cells)."""
    rows, cols = np.indices((24, 20))
    z = 500.0 - 10.0 * rows + 3.0 * np.sin(cols * 0.9) * np.cos(rows * 0.7)
    return write_geotiff(tmp_path / "ramp.tif", z.astype(np.float32))


def test_flow_discharge_sums_to_rain(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "q.tif"
    result = run_cli("flow", ramp, out, "--outlets", "S", "--precipitation", "0.5",
                     "--preview", tmp_path / "q.png")
    assert result.returncode == 0, result.stderr
    q = read_terrain(out).elevation
    assert q[-1].sum() == pytest.approx(0.5 * 24 * 20 * 900.0, rel=1e-6)
    assert (tmp_path / "q.png").stat().st_size > 10_000


def test_flow_receivers_are_d8_codes(tmp_path: Path, ramp: Path) -> None:
    out = tmp_path / "r.tif"
    result = run_cli("flow", ramp, out, "--what", "receivers", "--method", "d8", "--outlets", "S")
    assert result.returncode == 0, result.stderr
    codes = read_terrain(out).elevation
    assert set(np.unique(codes)) <= {0, 1, 2, 4, 8, 16, 32, 64, 128}
    assert (codes[-1] == 0).all()  # outlets
    assert (codes[:-1] != 0).all()


def test_erode_then_unerode_writes_everything(tmp_path: Path, ramp: Path) -> None:
    eroded, change = tmp_path / "e.tif", tmp_path / "dh.tif"
    result = run_cli("erode", ramp, eroded, "--dt", 100, "--steps", 4, "--outlets", "S",
                     "--K", "1e-4", "--K-d", "0.5", "--change-map", change,
                     "--snapshot-every", 200, "--preview", tmp_path / "e.png")
    assert result.returncode == 0, result.stderr
    sidecar = json.loads((tmp_path / "e.tif.json").read_text())
    budget = sidecar["statistics"]["mass_budget_m3"]["fluvial"]
    assert budget["eroded"] > 0
    assert abs(budget["residual"]) <= 1e-9 * budget["eroded"]
    assert sidecar["parameters"]["k"] == "1e-4"
    dh = read_terrain(change).elevation
    before, after = read_terrain(ramp).elevation, read_terrain(eroded).elevation
    np.testing.assert_allclose(after - before, dh, atol=1e-3)
    assert [p.name for p in sorted(tmp_path.glob("e_0*.tif"))] == ["e_001.tif", "e_002.tif"]
    assert (tmp_path / "dh.png").stat().st_size > 10_000  # the change map's own preview
    assert float(read_terrain(tmp_path / "e_001.tif").tags["UNERODE_TIME_Y"]) == 200.0

    back = tmp_path / "u.tif"
    result = run_cli("unerode", eroded, back, "--dt", 100, "--steps", 4, "--outlets", "S",
                     "--K", "1e-4", "--K-d", "0.5")
    assert result.returncode == 0, result.stderr
    restored = read_terrain(back)
    assert float(restored.tags["UNERODE_TIME_Y"]) == -400.0
    # going back in time raises the eroded terrain towards the original
    assert np.abs(restored.elevation - before).mean() < np.abs(after - before).mean()


def test_cfl_substeps_or_refusal(tmp_path: Path, ramp: Path) -> None:
    args = ["--dt", 1e5, "--steps", 1, "--outlets", "S", "--K", "1e-3", "--scheme", "explicit"]
    result = run_cli("erode", ramp, tmp_path / "a.tif", *args)
    assert result.returncode == 0, result.stderr
    assert "sub-step" in result.stderr
    sidecar = json.loads((tmp_path / "a.tif.json").read_text())
    assert sidecar["statistics"]["substeps"]["fluvial"] > 1
    out = tmp_path / "b.tif"
    assert_refused(run_cli("erode", ramp, out, *args, "--no-substep"), out, "unstable")


def test_the_default_takes_a_step_the_explicit_scheme_splits_whole(tmp_path: Path, ramp: Path) -> None:
    # --scheme auto (the default) runs implicit where the explicit scheme would need many
    # sub-steps: the step is taken whole, even with --no-substep
    args = ["--dt", 1e5, "--steps", 1, "--outlets", "S", "--K", "1e-3", "--no-substep"]
    result = run_cli("erode", ramp, tmp_path / "a.tif", *args)
    assert result.returncode == 0, result.stderr
    assert "sub-step" not in result.stderr
    sidecar = json.loads((tmp_path / "a.tif.json").read_text())
    assert sidecar["parameters"]["scheme"] == "auto"
    assert sidecar["statistics"]["fluvial_scheme"] == "implicit"
    assert sidecar["statistics"]["substeps"]["fluvial"] == 1
    assert sidecar["statistics"]["fluvial_implicit_passes"] >= 2
    budget = sidecar["statistics"]["mass_budget_m3"]["fluvial"]
    assert abs(budget["residual"]) <= 1e-9 * budget["eroded"]


def test_the_default_stays_explicit_where_the_step_is_stable(tmp_path: Path, ramp: Path) -> None:
    result = run_cli("erode", ramp, tmp_path / "a.tif", "--dt", 10, "--steps", 2, "--outlets", "S")
    assert result.returncode == 0, result.stderr
    sidecar = json.loads((tmp_path / "a.tif.json").read_text())
    assert sidecar["statistics"]["fluvial_scheme"] == "explicit"
    assert sidecar["statistics"]["substeps"]["fluvial"] == 2
    assert "fluvial_implicit_passes" not in sidecar["statistics"]


def test_bad_parameter_rasters(tmp_path: Path, ramp: Path) -> None:
    wrong_shape = write_geotiff(tmp_path / "k1.tif", np.full((5, 5), 1e-5, np.float32))
    wrong_crs = write_geotiff(tmp_path / "k2.tif", np.full((24, 20), 1e-5, np.float32),
                              crs="EPSG:32611")
    shifted = write_geotiff(tmp_path / "k3.tif", np.full((24, 20), 1e-5, np.float32),
                            transform=Affine(30, 0, 500030, 0, -30, 5000000))
    out = tmp_path / "o.tif"
    for raster, words in ((wrong_shape, "cells"), (wrong_crs, "crs"), (shifted, "aligned")):
        assert_refused(run_cli("erode", ramp, out, "--steps", 1, "--K", raster), out, words)


def test_parameter_raster_is_used(tmp_path: Path, ramp: Path) -> None:
    k = np.full((24, 20), 1e-4, np.float32)
    k[:, :10] = 0.0  # the west half does not erode
    k_map = write_geotiff(tmp_path / "k.tif", k)
    out = tmp_path / "o.tif"
    result = run_cli("erode", ramp, out, "--steps", 2, "--dt", 100, "--K", k_map, "--K-d", 0,
                     "--outlets", "S")
    assert result.returncode == 0, result.stderr
    change = read_terrain(out).elevation - read_terrain(ramp).elevation
    assert np.abs(change[:, :10]).max() == 0.0
    assert change[:-1, 10:].min() < 0.0


@pytest.mark.parametrize(("args", "words"), [
    (["--K", "-1"], "≥ 0"),
    (["--dt", "0"], "--dt"),
    (["--outlets", "none"], "no outlet"),
    (["--process", "lava"], "unknown process"),
    (["--duration", "150", "--dt", "100", "--steps", "3"], "exactly one"),
])
def test_bad_run_options(tmp_path: Path, ramp: Path, args: list[str], words: str) -> None:
    out = tmp_path / "o.tif"
    base = ["--steps", "1"] if "--steps" not in args else []
    assert_refused(run_cli("erode", ramp, out, *base, *args), out, words)
