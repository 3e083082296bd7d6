"""info, convert, preview and synth as a user runs them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import rasterio
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, run_cli

from unerode_cli.io.rasters import read_terrain


def test_info_json_of_sample(tmp_path: Path) -> None:
    result = run_cli("info", SAMPLE_DEMS / "coast_wgs84_30m.tif", "--json")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["epsg"] == 4326
    assert (summary["width"], summary["height"]) == (200, 200)
    assert summary["cell_size_m"] == pytest.approx([30.0, 30.0], rel=1e-3)
    assert summary["nodata_cells"] > 0
    assert summary["elevation_m"]["min"] >= 0.0


def test_convert_keeps_georeferencing_and_metadata(tmp_path: Path) -> None:
    source = SHARED_DATA / "dem/sangabriel_bigtujunga/bigtujunga.tif"
    if not source.exists():
        pytest.skip("shared DEM not available")
    out = tmp_path / "tujunga.tif"
    result = run_cli("convert", source, out, "--z-scale", "2")
    assert result.returncode == 0, result.stderr
    with rasterio.open(source) as a, rasterio.open(out) as b:
        assert b.crs == a.crs and b.transform == a.transform
        assert b.nodata == a.nodata == 32767
        assert b.dtypes[0] == "float32"
        assert b.profile["compress"] == "deflate" and b.profile["tiled"]
        assert b.tags()["AREA_OR_POINT"] == a.tags()["AREA_OR_POINT"]
        np.testing.assert_allclose(b.read(1), 2.0 * a.read(1).astype(np.float32))
        history = json.loads(b.tags()["UNERODE_HISTORY"])
    assert history[-1]["command"] == "convert"
    assert history[-1]["parameters"]["z_scale"] == 2.0
    sidecar = json.loads((tmp_path / "tujunga.tif.json").read_text())
    assert sidecar["command"] == "convert"


def test_history_accumulates_and_float64_and_cog(tmp_path: Path) -> None:
    first, second = tmp_path / "a.exr", tmp_path / "b.tif"
    assert run_cli("convert", SAMPLE_DEMS / "valley_utm32n_30m.tif", first).returncode == 0
    result = run_cli("convert", first, second, "--dtype", "float64", "--cog")
    assert result.returncode == 0, result.stderr
    with rasterio.open(second) as dst:
        assert dst.dtypes[0] == "float64"
        assert dst.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        commands = [e["command"] for e in json.loads(dst.tags()["UNERODE_HISTORY"])]
    assert commands == ["synth", "convert", "convert"]


def test_overwrite_replaces(tmp_path: Path, small_dem: Path) -> None:
    out = tmp_path / "out.tif"
    out.write_bytes(b"old")
    assert run_cli("convert", small_dem, out, "--overwrite").returncode == 0
    assert read_terrain(out).shape == (40, 50)


def test_preview_png(tmp_path: Path) -> None:
    png = tmp_path / "p.png"
    result = run_cli("preview", SAMPLE_DEMS / "coast_wgs84_30m.tif", png)
    assert result.returncode == 0, result.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size > 20_000
    named = tmp_path / "named.png"
    result = run_cli("preview", SAMPLE_DEMS / "coast_wgs84_30m.tif", named, "--label", "ice thickness (m)")
    assert result.returncode == 0, result.stderr
    assert named.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and named.read_bytes() != png.read_bytes()


def test_synth_is_reproducible(tmp_path: Path) -> None:
    paths = [tmp_path / f"{n}.tif" for n in ("a", "b", "c")]
    for path, seed in zip(paths, (5, 5, 6), strict=True):
        result = run_cli("synth", path, "--size", 64, "--seed", seed, "--kind", "mountain")
        assert result.returncode == 0, result.stderr
    a, b, c = (read_terrain(p) for p in paths)
    np.testing.assert_array_equal(a.elevation, b.elevation)
    assert np.abs(a.elevation - c.elevation).max() > 10.0
    assert a.elevation.min() < 0.0 < a.elevation.max()  # a coastline
    assert a.dx == pytest.approx(30.0)


def test_synth_geographic_cell_size(tmp_path: Path) -> None:
    out = tmp_path / "g.tif"
    result = run_cli("synth", out, "--size", 32, "--dx", 25, "--crs", "EPSG:4326",
                     "--centre", "10,60", "--kind", "fractal")
    assert result.returncode == 0, result.stderr
    terrain = read_terrain(out)
    assert (terrain.dx, terrain.dy) == pytest.approx((25.0, 25.0), rel=1e-3)
    assert terrain.transform.a == pytest.approx(-2.0 * terrain.transform.e, rel=0.01)  # cos 60° = 0.5
