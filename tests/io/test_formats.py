"""Output formats by extension, up-front output checks, corrupt inputs, RGB EXRs, creation
options and strict JSON."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
import rasterio
from affine import Affine
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pyproj import CRS, Transformer
from tests.conftest import run_cli, write_geotiff
from tests.io.test_roundtrip import terrains

from unerode_cli.errors import InputError
from unerode_cli.io import gdal_io
from unerode_cli.io.gdal_io import WriteOptions
from unerode_cli.io.json_files import read_json, to_json, write_json
from unerode_cli.io.provenance import history_entry, write_sidecar
from unerode_cli.io.rasters import check_writable, read_terrain, write_terrain
from unerode_cli.io.terrain import Terrain

GDAL_SUFFIXES = [".asc", ".img", ".bil", ".nc", ".gpkg"]
#: Files each format leaves for ``dem.SUFFIX`` with kept tags (nothing else, no temporaries).
FILES = {
    ".asc": {"dem.asc", "dem.prj", "dem.asc.aux.xml"},
    ".img": {"dem.img", "dem.img.aux.xml"},
    ".bil": {"dem.bil", "dem.hdr", "dem.bil.aux.xml"},
    ".nc": {"dem.nc"},
    ".gpkg": {"dem.gpkg"},
}
UTM32 = CRS.from_epsg(32632).to_wkt()
TRANSFORM = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)


def strict_loads(text: str) -> object:
    """json.loads that fails on NaN, Infinity and -Infinity."""
    def refuse(constant: str) -> None:
        raise ValueError(f"non-standard JSON constant {constant}")
    return json.loads(text, parse_constant=refuse)


def small_terrain() -> Terrain:
    """16 × 16 float32-exact elevations (m) with a 2 × 2 nodata hole, UTM 32N, 30 m cells."""
    rng = np.random.default_rng(3)
    data = (1000.0 + 100.0 * rng.random((16, 16))).astype(np.float32).astype(np.float64)
    data[2:4, 5:7] = np.nan
    return Terrain(data, 30.0, 30.0, UTM32, TRANSFORM, -9999.0, {"UNERODE_X": "1", "UNIT": "metre"})


# -- item 8: GDAL formats by extension ----------------------------------------------------------


@pytest.mark.parametrize("suffix", GDAL_SUFFIXES)
def test_gdal_format_round_trip_keeps_values_grid_and_leaves_only_its_files(
        tmp_path: Path, suffix: str) -> None:
    terrain = small_terrain()
    write_terrain(terrain, tmp_path / f"dem{suffix}")
    back = read_terrain(tmp_path / f"dem{suffix}")
    np.testing.assert_array_equal(back.nodata_mask, terrain.nodata_mask)
    np.testing.assert_allclose(back.elevation[~back.nodata_mask], terrain.elevation[~terrain.nodata_mask],
                               rtol=0, atol=1e-4)
    assert CRS.from_wkt(back.crs_wkt) == CRS.from_epsg(32632)
    assert back.transform.almost_equals(TRANSFORM, precision=1e-6)
    assert (back.dx, back.dy) == pytest.approx((30.0, 30.0))
    assert back.nodata == -9999.0
    if suffix != ".nc":  # netCDF keeps metadata under its own prefixed names
        assert back.tags["UNERODE_X"] == "1"
    assert {p.name for p in tmp_path.iterdir()} == FILES[suffix]


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(terrains(), st.sampled_from([".img", ".bil", ".asc"]))
def test_gdal_formats_keep_any_grid(terrain: Terrain, suffix: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"dem{suffix}"
        write_terrain(terrain, path)
        back = read_terrain(path)
    np.testing.assert_array_equal(back.nodata_mask, terrain.nodata_mask)
    np.testing.assert_array_equal(back.elevation[~back.nodata_mask], terrain.elevation[~terrain.nodata_mask])
    # the same coordinates, whatever the CRS's name (an ESRI .prj beside .asc renames datums)
    to_back = Transformer.from_crs(terrain.crs_wkt, back.crs_wkt, always_xy=True)
    corner = (terrain.transform.c, terrain.transform.f)
    assert to_back.transform(*corner) == pytest.approx(corner, abs=1e-3)
    scale = max(abs(terrain.transform.c), abs(terrain.transform.f), 1.0)
    assert back.transform.almost_equals(terrain.transform, precision=1e-9 * scale)


def test_convert_to_ascii_grid_as_the_readme_shows(tmp_path: Path) -> None:
    source = write_geotiff(tmp_path / "small.tif", np.arange(256, dtype=np.float32).reshape(16, 16))
    result = run_cli("convert", source, tmp_path / "out.asc")
    assert result.returncode == 0, result.stderr
    text = (tmp_path / "out.asc").read_text()
    assert text.splitlines()[:5] == ["ncols        16", "nrows        16", "xllcorner    500000.000000000000",
                                     "yllcorner    4999520.000000000000", "cellsize     30.000000000000"]
    np.testing.assert_array_equal(read_terrain(tmp_path / "out.asc").elevation,
                                  np.arange(256.0).reshape(16, 16))


def test_envi_bil_input_is_written_back_as_bil(tmp_path: Path) -> None:
    data = np.arange(256, dtype=np.float32).reshape(16, 16) + 500.0
    data[0, 0] = -9999.0
    with rasterio.open(tmp_path / "in.bil", "w", driver="ENVI", height=16, width=16, count=1,
                       dtype="float32", crs="EPSG:32644", transform=TRANSFORM, nodata=-9999.0) as dst:
        dst.write(data, 1)
    (tmp_path / "out").mkdir()
    result = run_cli("convert", tmp_path / "in.bil", tmp_path / "out" / "dem.bil")
    assert result.returncode == 0, result.stderr
    assert {p.name for p in (tmp_path / "out").iterdir()} == {"dem.bil", "dem.hdr", "dem.bil.aux.xml",
                                                              "dem.bil.json"}
    with rasterio.open(tmp_path / "out" / "dem.bil") as src:
        assert src.driver == "ENVI" and src.crs.to_epsg() == 32644 and src.transform == TRANSFORM
        assert src.nodata == -9999.0
        np.testing.assert_array_equal(src.read(1), data)


def test_failed_write_leaves_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def write_then_fail(terrain: Terrain, path: Path, options: WriteOptions) -> None:
        real_write(terrain, path, options)  # the raster and its .hdr exist, then GDAL fails
        raise rasterio.errors.RasterioIOError("disk full")

    check_writable(tmp_path / "dem.bil", WriteOptions())  # as planning does; the result is kept
    real_write = gdal_io._write
    monkeypatch.setattr(gdal_io, "_write", write_then_fail)
    with pytest.raises(InputError, match=r"^cannot write .*dem\.bil: disk full\.$"):
        write_terrain(small_terrain(), tmp_path / "dem.bil")
    assert list(tmp_path.iterdir()) == []


def test_netcdf_refuses_a_projection_without_cf_grid_mapping(tmp_path: Path) -> None:
    swiss = Terrain(np.zeros((16, 16)), 30.0, 30.0, CRS.from_epsg(2056).to_wkt(),
                    Affine(30.0, 0.0, 2600000.0, 0.0, -30.0, 1200000.0))
    refused = r"dem\.nc: the netCDF format cannot hold the projection 'Hotine Oblique Mercator \(variant B\)'"
    with pytest.raises(InputError, match=refused + r"; write a \.tif instead\.$"):
        write_terrain(swiss, tmp_path / "dem.nc")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, options, message", [
    ("dem", WriteOptions(), r"^cannot write .*dem: it has no extension; end its name with one of \.exr, "),
    ("dem.xyz1", WriteOptions(), r"'\.xyz1' is no known raster extension; .* \.asc, \.img, \.bil"),
    ("dem.asc", WriteOptions(cog=True), r"^--cog needs a \.tif output, got .*dem\.asc\.$"),
    ("dem.exr", WriteOptions(dtype="float64"), r"^EXR outputs are always float32 ZIP"),
    ("dem.exr", WriteOptions(cog=True), r"^EXR outputs are always float32 ZIP"),
    ("dem.exr", WriteOptions(creation_options={"COMPRESS": "NONE"}), r"^EXR outputs are always float32"),
    ("dem.gpkg", WriteOptions(dtype="float64"), r"GPKG driver cannot write float64 cells \(Only Byte"),
    ("dem.tif", WriteOptions(creation_options={"COMPRESS": "NOPE"}),
     r"--co COMPRESS=NOPE is not accepted by GDAL's GTiff driver \('NOPE' is an unexpected value"),
    ("dem.tif", WriteOptions(creation_options={"FOO": "1"}), r"--co FOO=1 is not accepted by GDAL's GTiff"),
    ("dem.asc", WriteOptions(creation_options={"COMPRESS": "DEFLATE"}),
     r"--co COMPRESS=DEFLATE is not accepted by GDAL's AAIGrid driver"),
])
def test_check_writable_refuses_what_could_not_be_written(tmp_path: Path, name: str, options: WriteOptions,
                                                          message: str) -> None:
    with pytest.raises(InputError, match=message):
        check_writable(tmp_path / name, options)
    with pytest.raises(InputError, match=message):
        write_terrain(small_terrain(), tmp_path / name, options)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, options", [
    ("dem.tif", WriteOptions()),
    ("dem.TIF", WriteOptions(dtype="float64", cog=True)),
    ("dem.tif", WriteOptions(creation_options={"COMPRESS": "LZW", "PREDICTOR": "2"})),
    ("dem.exr", WriteOptions()),
    ("dem.img", WriteOptions(dtype="float64")),
    ("dem.bil", WriteOptions(creation_options={"INTERLEAVE": "BSQ"})),
    ("dem.nc", WriteOptions(creation_options={"FORMAT": "NC4"})),
    ("dem.gpkg", WriteOptions()),
])
def test_check_writable_accepts_what_can_be_written(tmp_path: Path, name: str, options: WriteOptions) -> None:
    check_writable(tmp_path / name, options)
    write_terrain(small_terrain(), tmp_path / name, options)
    assert read_terrain(tmp_path / name).shape == (16, 16)


def test_output_without_extension_names_the_users_path(tmp_path: Path) -> None:
    source = write_geotiff(tmp_path / "small.tif", np.ones((16, 16), np.float32))
    result = run_cli("convert", source, tmp_path / "noext")
    assert result.returncode == 2
    assert f"cannot write {tmp_path / 'noext'}: it has no extension" in result.stderr
    assert ".part" not in result.stderr


# -- item 5: truncated GeoTIFFs ---------------------------------------------------------------


@pytest.mark.parametrize("cog", [False, True], ids=["directory-last", "directory-first"])
@pytest.mark.parametrize("command", ["info", "convert"])
def test_truncated_geotiff_is_bad_input_in_one_sentence(tmp_path: Path, cog: bool, command: str) -> None:
    whole = tmp_path / "whole.tif"
    rng = np.random.default_rng(0)
    write_terrain(small_terrain().with_elevation(rng.random((16, 16)) * 1000.0), whole, WriteOptions(cog=cog))
    cut = tmp_path / "cut.tif"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    args = [command, cut] + ([tmp_path / "out.tif"] if command == "convert" else [])
    result = run_cli(*args)
    assert result.returncode == 2, result.stderr
    assert f"error: {cut} is truncated or corrupt (" in result.stderr
    assert "Traceback" not in result.stderr and "RasterioIOError" not in result.stderr
    assert not (tmp_path / "out.tif").exists()


def test_a_file_that_is_no_raster_is_still_said_to_be_none(tmp_path: Path) -> None:
    text = tmp_path / "notes.tif"
    text.write_text("not a raster\n")
    with pytest.raises(InputError, match=r"notes\.tif is not a raster that GDAL can read"):
        read_terrain(text)


# -- item 9: RGB EXRs ----------------------------------------------------------------------------


@pytest.fixture
def rgb_exr(tmp_path: Path) -> Path:
    red = 1000.0 + np.arange(256, dtype=np.float32).reshape(16, 16)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    path = tmp_path / "rgb.exr"
    OpenEXR.File(header, {"R": red, "G": red + 100.0, "B": red + 200.0}).write(str(path))
    return path


def test_rgb_exr_is_read_from_red(rgb_exr: Path) -> None:
    np.testing.assert_array_equal(read_terrain(rgb_exr).elevation,
                                  1000.0 + np.arange(256.0).reshape(16, 16))


def test_rgb_exr_green_channel_on_request(rgb_exr: Path) -> None:
    np.testing.assert_array_equal(read_terrain(rgb_exr, channel="G").elevation,
                                  1100.0 + np.arange(256.0).reshape(16, 16))


def test_rgb_exr_channel_rgb_is_a_sentence(rgb_exr: Path, tmp_path: Path) -> None:
    result = run_cli("convert", rgb_exr, tmp_path / "out.tif", "--channel", "RGB")
    assert result.returncode == 2
    assert f"error: {rgb_exr} has no channel 'RGB' (it has: B, G, R)." in result.stderr


# -- item 10: creation options -------------------------------------------------------------------


@pytest.mark.parametrize("option, message", [
    ("COMPRESS=NOPE", "--co COMPRESS=NOPE is not accepted by GDAL's GTiff driver ('NOPE' is an unexpected "
                      "value for COMPRESS creation option of type string-select)."),
    ("BOGUS=1", "--co BOGUS=1 is not accepted by GDAL's GTiff driver (driver GTiff does not support "
                "creation option BOGUS)."),
    ("ZLEVEL=42", "--co ZLEVEL=42 is not accepted by GDAL's GTiff driver (ZLEVEL=42 value not recognised, "
                  "ignoring)."),
    ("PREDICTOR=9", "GDAL's GTiff driver cannot write float32 cells with --co PREDICTOR=9 "
                    "(PREDICTOR=9 is not supported)."),
    ("BLOCKXSIZE=7", "GDAL's GTiff driver cannot write float32 cells with --co BLOCKXSIZE=7 "
                     "(The height and width of TIFF dataset blocks must be multiples of 16)."),
])
def test_creation_option_gdal_rejects_is_refused_before_any_work(tmp_path: Path, option: str,
                                                                  message: str) -> None:
    source = write_geotiff(tmp_path / "small.tif", np.ones((16, 16), np.float32))
    result = run_cli("convert", source, tmp_path / "out.tif", "--co", option)
    assert result.returncode == 2
    assert result.stderr == f"error: cannot write {tmp_path / 'out.tif'}: {message}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["small.tif"]


# -- item 11: strict JSON --------------------------------------------------------------------------


def test_sidecar_with_nan_statistics_is_strict_json(tmp_path: Path) -> None:
    entry = history_entry("convert", {"z_scale": np.float64(np.inf), "input": tmp_path / "in.tif"})
    statistics = {"mean_m": float("nan"), "max_m": np.float32(np.nan), "cells": np.int64(4),
                  "profile": np.array([1.5, np.nan, -np.inf]), "nested": {"low": (np.float64(-np.inf), 2.0)}}
    sidecar = write_sidecar(tmp_path / "out.tif", entry, statistics)
    payload = strict_loads(sidecar.read_text())
    assert payload["statistics"] == {"mean_m": None, "max_m": None, "cells": 4, "profile": [1.5, None, None],
                                     "nested": {"low": [None, 2.0]}}
    assert payload["parameters"] == {"z_scale": None, "input": str(tmp_path / "in.tif")}


def test_write_json_never_writes_nan(tmp_path: Path) -> None:
    write_json(tmp_path / "r.json", {"a": [np.float32(1.5), float("nan")]})
    assert strict_loads((tmp_path / "r.json").read_text()) == {"a": [1.5, None]}
    assert read_json(tmp_path / "r.json") == {"a": [1.5, None]}
    assert to_json({"x": float("inf")}) == '{"x": null}'
