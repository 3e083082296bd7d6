"""Property tests: GeoTIFF and EXR round trips keep values, mask, CRS and transform exactly."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from affine import Affine
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from pyproj import CRS

from unerode_cli.io.rasters import read_terrain, write_terrain
from unerode_cli.io.terrain import Terrain

PROJECTED_EPSG = [32632, 32611, 32718, 2056, 3035, 27700, 2154, 3857, 5070, 32644]

finite_f32 = st.floats(-11000, 9000, width=32, allow_nan=False, allow_infinity=False)


@st.composite
def terrains(draw) -> Terrain:
    ny = draw(st.integers(2, 40))
    nx = draw(st.integers(2, 40))
    data = draw(arrays(np.float32, (ny, nx), elements=finite_f32)).astype(np.float64)
    holes = draw(arrays(np.bool_, (ny, nx), elements=st.booleans()))
    holes[0, 0] = False  # keep at least one valid cell
    data[holes] = np.nan
    epsg = draw(st.sampled_from(PROJECTED_EPSG))
    px = draw(st.floats(0.5, 500.0, width=32))
    py = draw(st.floats(0.5, 500.0, width=32))
    x0 = draw(st.floats(-1e6, 1e6, width=32))
    y0 = draw(st.floats(-1e6, 9e6, width=32))
    transform = Affine(px, 0.0, x0, 0.0, -py, y0)
    nodata = -9999.0 if holes.any() else None
    return Terrain(data, px, py, CRS.from_epsg(epsg).to_wkt(), transform, nodata, {})


def assert_same(a: Terrain, b: Terrain) -> None:
    np.testing.assert_array_equal(a.nodata_mask, b.nodata_mask)
    np.testing.assert_array_equal(a.elevation[~a.nodata_mask], b.elevation[~b.nodata_mask])
    assert CRS.from_wkt(a.crs_wkt) == CRS.from_wkt(b.crs_wkt)
    assert tuple(a.transform) == tuple(b.transform)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(terrains(), st.sampled_from([".tif", ".exr"]))
def test_round_trip_is_exact(terrain: Terrain, suffix: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"dem{suffix}"
        write_terrain(terrain, path)
        back = read_terrain(path)
    assert_same(terrain, back)
    assert back.dx == terrain.dx and back.dy == terrain.dy


@settings(max_examples=15, deadline=None)
@given(terrains())
def test_geotiff_exr_geotiff_is_exact(terrain: Terrain) -> None:
    with tempfile.TemporaryDirectory() as folder:
        first, middle, last = (Path(folder) / n for n in ("a.tif", "b.exr", "c.tif"))
        write_terrain(terrain, first)
        write_terrain(read_terrain(first), middle)
        write_terrain(read_terrain(middle), last)
        back = read_terrain(last)
    assert_same(terrain, back)
    assert (back.nodata is None) == (terrain.nodata is None)


def test_float64_output_keeps_full_precision(tmp_path: Path) -> None:
    from unerode_cli.io.gdal_io import WriteOptions

    data = np.array([[1000.123456789012, 2.0], [3.0, 4.000000000001]])
    terrain = Terrain(data, 1.0, 1.0, CRS.from_epsg(32632).to_wkt(),
                      Affine(1, 0, 0, 0, -1, 2), None, {})
    write_terrain(terrain, tmp_path / "d.tif", WriteOptions(dtype="float64"))
    back = read_terrain(tmp_path / "d.tif")
    assert back.elevation[0, 0] == 1000.123456789012
    assert back.elevation[1, 1] == 4.000000000001
