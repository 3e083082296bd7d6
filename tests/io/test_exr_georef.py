"""EXR georeferencing: the CRS as WKT2 in the documented ``crs`` header attribute, the old
``unerode.crsWkt`` still read, and a CRS and cell size assigned to an EXR without any."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from affine import Affine
from pyproj import CRS
from rasterio.crs import CRS as RioCRS

from unerode_cli.io.exr_io import CRS_ATTRIBUTE
from unerode_cli.io.input_georef import InputGeoref
from unerode_cli.io.rasters import read_header, read_terrain, write_terrain
from unerode_cli.io.terrain import Terrain

UTM = CRS.from_epsg(32632)
TRANSFORM = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)


def _elevation() -> np.ndarray:
    return 100.0 + np.arange(20, dtype=np.float64).reshape(4, 5)


def _header(path: Path) -> dict:
    with OpenEXR.File(str(path), header_only=True) as exr:
        return dict(exr.header())


def _write_raw(path: Path, attributes: dict[str, str]) -> None:
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}
    OpenEXR.File(header, {"Y": _elevation().astype(np.float32)}).write(str(path))


def test_written_exr_keeps_its_crs_as_wkt2_in_the_crs_attribute(tmp_path: Path) -> None:
    path = tmp_path / "dem.exr"
    write_terrain(Terrain(_elevation(), 30.0, 30.0, RioCRS.from_epsg(32632).to_wkt(), TRANSFORM), path)
    header = _header(path)
    assert header[CRS_ATTRIBUTE].startswith("PROJCRS[")          # WKT2, not WKT1's PROJCS[
    assert CRS.from_wkt(header[CRS_ATTRIBUTE]) == UTM
    assert "unerode.crsWkt" not in header
    back = read_terrain(path)
    assert CRS.from_wkt(back.crs_wkt) == UTM
    assert back.transform == TRANSFORM and (back.dx, back.dy) == (30.0, 30.0)
    np.testing.assert_array_equal(back.elevation, _elevation())


def test_an_exr_written_before_the_crs_attribute_still_reads(tmp_path: Path) -> None:
    path = tmp_path / "old.exr"
    _write_raw(path, {"unerode.crsWkt": RioCRS.from_epsg(32632).to_wkt(),   # WKT1, as GDAL gives it
                      "unerode.transform": json.dumps(list(TRANSFORM)[:6]), "unerode.cellSize": "30.0 30.0",
                      "unerode.nodata": "null", "unerode.tags": "{}"})
    back = read_terrain(path)
    assert CRS.from_wkt(back.crs_wkt) == UTM and back.transform == TRANSFORM
    assert CRS.from_wkt(read_header(path).crs_wkt) == UTM


def test_crs_and_cell_size_are_assigned_to_a_bare_exr(tmp_path: Path) -> None:
    path = tmp_path / "houdini.exr"
    _write_raw(path, {})
    plain = read_terrain(path)
    assert (plain.dx, plain.dy, plain.crs_wkt) == (1.0, 1.0, "")
    georef = InputGeoref("EPSG:32632", 30.0, 105.0)
    terrain = read_terrain(path, georef=georef)
    assert CRS.from_wkt(terrain.crs_wkt) == UTM
    assert terrain.transform == Affine(30.0, 0.0, 0.0, 0.0, -30.0, 4 * 30.0)
    assert (terrain.dx, terrain.dy) == pytest.approx((30.0, 30.0), rel=1e-12)
    assert terrain.nodata == 105.0 and np.isnan(terrain.elevation[1, 0])     # the cell equal to --nodata
    assert np.isfinite(terrain.elevation).sum() == 19
    header = read_header(path, georef=georef)
    assert header.transform == terrain.transform and CRS.from_wkt(header.crs_wkt) == UTM
