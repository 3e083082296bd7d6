"""`glaciate` on crops of real DEMs (../shared/data): nodata voids and a geographic CRS run with
plausible speeds and erosion; a run that diverges stops at that step, exit 1, nothing written."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from tests.conftest import SAMPLE_DEMS, SHARED_DATA, run_cli, write_geotiff

from unerode_cli.io.rasters import read_terrain, write_terrain

GRINDELWALD = SHARED_DATA / "dem" / "alps_grindelwald" / "dem.tif"
PATAGONIA = SHARED_DATA / "dem" / "patagonia_exploradores" / "AST_L1A_00303182012144228_Z.tif"
needs_data = pytest.mark.skipif(not (GRINDELWALD.exists() and PATAGONIA.exists()),
                                reason="needs ../shared/data/dem")


def crop(source: Path, rows: slice, cols: slice, out: Path) -> Path:
    """Write the window (rows, cols) of ``source`` to ``out`` with the project's io."""
    terrain = read_terrain(source)
    window = dataclasses.replace(terrain, elevation=terrain.elevation[rows, cols].copy(), tags={},
                                 transform=terrain.transform @ Affine.translation(cols.start, rows.start))
    write_terrain(window, out)
    return out


def files_in(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


def _plausible(tmp_path: Path, dem: Path, out: Path, years: float, *extra: object) -> dict:
    """Run glaciate with the default physics and check what every real-DEM run must meet: exit
    0, nodata kept, bed lowered (or raised, where hill slopes deposit at their foot) by at most
    0.1 m/y anywhere (measured glacial erosion is 0.01–10 mm/y, rock-wall retreat 0.1–2 mm/y),
    surface speeds below 1000 m/y. Returns the arrays for further checks."""
    velocity, ice = out.with_name(out.stem + "_v.tif"), out.with_name(out.stem + "_ice.tif")
    result = run_cli("glaciate", dem, out, "--ela", 2900, "--duration", years, "--dt", 20,
                     "--velocity", velocity, "--ice", ice, "--dtype", "float64", *extra)
    assert result.returncode == 0, result.stderr
    before, after = read_terrain(dem).elevation, read_terrain(out).elevation
    np.testing.assert_array_equal(np.isnan(after), np.isnan(before))  # voids stay voids
    lowering = (before - after)[np.isfinite(before)]
    assert np.abs(lowering).max() / years < 0.1
    h = read_terrain(ice).elevation
    with rasterio.open(velocity) as src:
        bands = src.read(masked=True).astype(float)
        speed = np.hypot(*bands.filled(np.nan))
    assert np.nanmax(h) > 10.0  # glaciers did form
    np.testing.assert_array_equal(np.isnan(speed), np.isnan(before))  # nodata where the DEM has
    assert np.nanmax(speed) < 1000.0
    stats = json.loads(out.with_name(out.name + ".json").read_text())["statistics"]
    return {"lowering": before - after, "h": h, "speed": speed, "stats": stats}


@needs_data
def test_a_dem_with_nodata_voids_glaciates_plausibly(tmp_path: Path) -> None:
    """A 32 × 32 window of the ASTER DEM of Exploradores (30 m, 2 100–3 700 m) with 14 % voids
    under an ELA of 2900 m: no error, voids kept, no ice and no erosion in them, sliding of m/y."""
    dem = crop(PATAGONIA, slice(392, 424), slice(56, 88), tmp_path / "patagonia.tif")
    voids = read_terrain(dem).nodata_mask
    assert 0.05 < voids.mean() < 0.3
    run = _plausible(tmp_path, dem, tmp_path / "bed.tif", 60.0)
    assert np.all(np.isnan(run["h"][voids]) | (run["h"][voids] == 0.0))
    assert np.nanmax(run["lowering"]) > 0.0  # the ice did slide and erode


@needs_data
def test_a_geographic_dem_glaciates_like_its_projected_twin(tmp_path: Path) -> None:
    """The same 24 × 24 window of Grindelwald (46 m) written once in its metric CRS and once in
    WGS 84 degrees (cells of the same size in metres at 46.6° N): the runs agree."""
    projected = crop(GRINDELWALD, slice(216, 240), slice(164, 188), tmp_path / "tm.tif")
    terrain = read_terrain(projected)
    lat = math.radians(46.6)
    m_per_deg_lat = 111132.954 - 559.822 * math.cos(2 * lat) + 1.175 * math.cos(4 * lat)
    m_per_deg_lon = 111412.84 * math.cos(lat) - 93.5 * math.cos(3 * lat)
    geographic = write_geotiff(tmp_path / "wgs84.tif", terrain.elevation.astype(np.float32),
                               Affine(46.0 / m_per_deg_lon, 0.0, 8.05, 0.0, -46.0 / m_per_deg_lat, 46.6),
                               crs="EPSG:4326")
    read = read_terrain(geographic)
    assert read.dx == pytest.approx(46.0, rel=0.01) and read.dy == pytest.approx(46.0, rel=0.01)
    a = _plausible(tmp_path, projected, tmp_path / "a.tif", 30.0)
    b = _plausible(tmp_path, geographic, tmp_path / "b.tif", 30.0)
    with rasterio.open(tmp_path / "b.tif") as src:
        assert src.crs.to_epsg() == 4326
    assert b["stats"]["eroded_volume_m3"] == pytest.approx(a["stats"]["eroded_volume_m3"], rel=0.05)
    assert b["stats"]["final_ice_volume_m3"] == pytest.approx(a["stats"]["final_ice_volume_m3"], rel=0.03)


def test_a_diverging_run_stops_at_that_step_exit_1_and_writes_nothing(tmp_path: Path) -> None:
    """An absurdly slippery bed (C = 10 Pa·(y/m)^½: 10⁸ m/y of sliding under 100 kPa) makes the
    abrasion run away in the first step with ice flow: the run stops there (step 2, after the
    10-year ramp step; the spikes of ice it makes first have that step taken again at shorter
    lengths, ``coupled.surface_overshoot``), exit 1, and the snapshot of 10 y already written is
    removed; no preview and no output are left behind."""
    dem = crop(SAMPLE_DEMS / "valley_utm32n_30m.tif", slice(0, 32), slice(0, 32), tmp_path / "v.tif")
    before = files_in(tmp_path)
    result = run_cli("glaciate", dem, tmp_path / "out.tif", "--ela", 800, "--duration", 30, "--dt", 30,
                     "--iceflow", "sia", "--sliding-C", 10, "--snapshot-every", 10,
                     "--preview", tmp_path / "out.png", "--ice", tmp_path / "ice.tif")
    assert result.returncode == 1, result.stderr
    found = re.search(r"diverged in step 2 \(t = ([0-9.]+) y\)", result.stderr)
    assert found and 10.0 < float(found.group(1)) <= 25.0, result.stderr
    assert "Traceback" not in result.stderr
    assert files_in(tmp_path) == before


def test_an_explicit_step_far_above_its_stability_limit_exits_1_at_once(tmp_path: Path) -> None:
    """Explicit transport in steps of 1000 y: the first lays up to 2 km of ice on the bare crop,
    the second would need millions of sub-steps under it and stops before its first, exit 1,
    nothing written."""
    dem = crop(SAMPLE_DEMS / "valley_utm32n_30m.tif", slice(0, 32), slice(0, 32), tmp_path / "v.tif")
    before = files_in(tmp_path)
    result = run_cli("glaciate", dem, tmp_path / "out.tif", "--ela", 800, "--duration", 2000, "--dt", 1000,
                     "--iceflow", "sia", "--transport", "explicit", "--ice", tmp_path / "ice.tif")
    assert result.returncode == 1, result.stderr
    assert "explicit sub-steps" in result.stderr and "multi-scale transport" in result.stderr, result.stderr
    assert "Traceback" not in result.stderr
    assert files_in(tmp_path) == before


def test_a_sane_run_of_the_same_crop_is_not_stopped(tmp_path: Path) -> None:
    """The guard does not fire on the same crop with the default sliding: the bound can fail."""
    dem = crop(SAMPLE_DEMS / "valley_utm32n_30m.tif", slice(0, 32), slice(0, 32), tmp_path / "v.tif")
    result = run_cli("glaciate", dem, tmp_path / "out.tif", "--ela", 800, "--duration", 30, "--dt", 30)
    assert result.returncode == 0, result.stderr
    lowering = read_terrain(dem).elevation - read_terrain(tmp_path / "out.tif").elevation
    assert 0.0 < lowering.max() < 0.1 * 30
