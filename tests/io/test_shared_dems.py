"""Real DEMs of ../shared/data read with the CRS, size and elevation range of PROVENANCE.md."""

from __future__ import annotations

import numpy as np
import pytest
from pyproj import CRS
from tests.conftest import SHARED_DATA

from unerode_cli.io.rasters import read_terrain

DEM = SHARED_DATA / "dem"

# file, EPSG (None: custom CRS), (columns, rows), (min, max) m, mean m, nodata cells, cell size m
CASES = [
    ("alps_grindelwald/dem.tif", None, (344, 333), (816.4, 3996.2), 2424.5, 0, (46.0, 46.0)),
    ("alps_oetztal/srtm_oetztal.tif", 4326, (582, 444), (387, 3727), 2504.7, 0, (64.0, 93.0)),
    ("patagonia_exploradores/AST_L1A_00303182012144228_Z.tif", 32718, (539, 618),
     (317.7, 3959.9), 1497.3, 8908, (30.0, 30.0)),
    ("sangabriel_bigtujunga/bigtujunga.tif", 32611, (1197, 643), (315, 2295), 1226.6, 0,
     (30.0, 30.0)),
    ("himalaya_mandakini/Mandakini.bil", 32644, (587, 648), (644, 6741), 2682.2, 172089,
     (88.814, 88.814)),
]


@pytest.mark.parametrize(("name", "epsg", "size", "zrange", "zmean", "voids", "cell"), CASES)
def test_shared_dem_matches_provenance(name, epsg, size, zrange, zmean, voids, cell) -> None:
    path = DEM / name
    if not path.exists():
        pytest.skip(f"{path} is not available")
    terrain = read_terrain(path)
    crs = CRS.from_wkt(terrain.crs_wkt)
    assert crs.to_epsg() == epsg
    assert terrain.shape == (size[1], size[0])
    z = terrain.elevation[~terrain.nodata_mask]
    assert z.min() == pytest.approx(zrange[0], abs=0.06)
    assert z.max() == pytest.approx(zrange[1], abs=0.06)
    assert z.mean() == pytest.approx(zmean, abs=0.06)
    assert int(terrain.nodata_mask.sum()) == voids
    assert (terrain.dx, terrain.dy) == pytest.approx(cell, rel=0.02)
    assert np.isnan(terrain.elevation[terrain.nodata_mask]).all()


def test_grindelwald_custom_transverse_mercator() -> None:
    path = DEM / "alps_grindelwald/dem.tif"
    if not path.exists():
        pytest.skip(f"{path} is not available")
    crs = CRS.from_wkt(read_terrain(path).crs_wkt)
    assert crs.is_projected
    assert crs.to_dict()["proj"] == "tmerc"
    assert crs.to_dict()["lon_0"] == pytest.approx(8.11933)
