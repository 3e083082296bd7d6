"""`synth`'s default relief follows the extent: the land's median slope is at most 30° (the real
mountain DEMs of ``../shared/data``: 22–28°), so the project's own synthetic terrains are ones
the DEM sanity check (run/terrain_sanity.py) accepts at any size; a given ``--relief`` is kept."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from tests.conftest import SAMPLE_DEMS
from tests.refusals import cli

from unerode_cli.io.rasters import read_terrain
from unerode_cli.run.terrain_sanity import cliff_share, implausible
from unerode_cli.synthetic import relief_for_extent, shape_of


def land_median_slope(z: np.ndarray, dx: float, dy: float) -> float:
    """Median slope (degrees, central differences) of the cells above 0 m that have one."""
    gy, gx = np.gradient(z, dy, dx)
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    return float(np.median(slope[np.isfinite(slope) & (z > 0.0)]))


@pytest.mark.parametrize("kind, size, dx, relief", [
    # the reliefs are measurements of the synthetic terrains (seed 1)
    ("mountain", 16, 30.0, 163.0), ("mountain", 32, 30.0, 249.0), ("mountain", 256, 30.0, 1139.0),
    ("mountain", 512, 30.0, 1760.0), ("mountain", 1024, 30.0, 2000.0), ("fractal", 32, 30.0, 234.0),
    ("fractal", 256, 30.0, 993.0), ("fractal", 256, 250.0, 2000.0),
])
def test_the_default_relief_keeps_the_median_slope_of_mountains(tmp_path: Path, kind: str, size: int,
                                                                dx: float, relief: float) -> None:
    code, stderr = cli(tmp_path, "synth", "out.tif", "--kind", kind, "--size", size, "--dx", dx, "-q")
    assert code == 0, stderr
    terrain = read_terrain(tmp_path / "out.tif")
    recorded = json.loads((tmp_path / "out.tif.json").read_text())["parameters"]["relief"]
    assert recorded == pytest.approx(relief, rel=0.002)
    slope = land_median_slope(terrain.elevation, terrain.dx, terrain.dy)
    if relief < 2000.0:
        assert slope == pytest.approx(30.0, abs=0.05)
    else:                              # 2000 m is gentler than 30° on this extent
        assert slope < 30.0
    assert cliff_share(terrain.elevation, terrain.dx, terrain.dy) < 0.012      # measured 0–1.17 %
    assert implausible(terrain) == ""


def test_a_geographic_grid_takes_its_cells_in_metres(tmp_path: Path) -> None:
    reliefs = []
    for name, crs, centre in (("g.tif", "EPSG:4326", "10,60"), ("p.tif", "EPSG:32632", "650000,5200000")):
        code, stderr = cli(tmp_path, "synth", name, "--size", 64, "--dx", 25, "--crs", crs, "--centre",
                           centre, "-q")
        assert code == 0, stderr
        terrain = read_terrain(tmp_path / name)
        assert (terrain.dx, terrain.dy) == pytest.approx((25.0, 25.0), rel=1e-3)
        assert land_median_slope(terrain.elevation, terrain.dx, terrain.dy) == pytest.approx(30.0, abs=0.05)
        reliefs.append(json.loads((tmp_path / f"{name}.json").read_text())["parameters"]["relief"])
    # 25 m cells in degrees (0.00045° × 0.00022°) or in metres: one relief, 350 m
    assert reliefs[0] == pytest.approx(reliefs[1], rel=1e-3)
    assert reliefs[1] == pytest.approx(350.1, abs=0.5)


def test_a_given_relief_is_kept(tmp_path: Path) -> None:
    # sample_dems/README.md's command of the valley sample, made with synth's former default
    code, stderr = cli(tmp_path, "synth", "v.tif", "--kind", "mountain", "--size", 256, "--dx", 30,
                       "--seed", 7, "--relief", 2000, "--crs", "EPSG:32632", "--centre", "650000,5200000",
                       "-q")
    assert code == 0, stderr
    made, sample = read_terrain(tmp_path / "v.tif"), read_terrain(SAMPLE_DEMS / "valley_utm32n_30m.tif")
    np.testing.assert_array_equal(made.elevation, sample.elevation)
    assert json.loads((tmp_path / "v.tif.json").read_text())["parameters"]["relief"] == 2000.0
    # 2000 m on 256 cells of 30 m is steeper than mountains (a median of 49.6° on land), yet passes
    assert land_median_slope(made.elevation, made.dx, made.dy) == pytest.approx(49.6, abs=0.1)
    assert cliff_share(made.elevation, made.dx, made.dy) == pytest.approx(0.1201, abs=0.0005)


def test_relief_for_extent_scales_the_median_gradient() -> None:
    relative = shape_of("fractal", (64, 64), 2)
    gy, gx = np.gradient(relative, 30.0, 30.0)
    median = np.median(np.hypot(gx, gy)[relative > 0.0])
    assert relief_for_extent(relative, 30.0, 30.0) == pytest.approx(np.tan(np.radians(30.0)) / median,
                                                                    rel=1e-12)
    assert relief_for_extent(relative, 30.0, 30.0, median_slope_deg=45.0) == pytest.approx(1.0 / median,
                                                                                           rel=1e-12)
    assert relief_for_extent(relative, 3000.0, 3000.0) == 2000.0           # a gentle extent: the cap
    assert relief_for_extent(np.zeros((8, 8)), 30.0, 30.0) == 2000.0      # no land: the cap
