"""Non-finite geometry refused (issue 45, class 5) and a picture given as a DEM (class 7): a
geotransform or an extent that is not finite, a geographic raster whose rows pass a pole, a
cell size that comes out NaN, synth grids that do not fit on the globe or in double precision,
a --z-scale that makes elevations non-finite, and a raster without georeferencing: each is one
sentence, exit 2, before any computation, with no file left."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from pyproj import CRS
from tests.conftest import write_geotiff
from tests.refusals import assert_refused, cli

from unerode_cli.errors import InputError
from unerode_cli.io.cellsize import cell_size_metres
from unerode_cli.io.georef import centred_transform
from unerode_cli.io.rasters import read_header, read_terrain
from unerode_cli.io.resampling import crop_window, resampled_shape

WGS84 = CRS.from_epsg(4326).to_wkt()
UTM = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    rows = np.indices((24, 24))[0]
    write_geotiff(tmp_path / "in.tif", (400.0 + 5.0 * rows).astype(np.float32))
    return tmp_path


def png(path: Path) -> Path:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with rasterio.open(path, "w", driver="PNG", height=16, width=16, count=1, dtype="uint8") as dst:
            dst.write(np.arange(256, dtype=np.uint8).reshape(16, 16), 1)
    return path


# --- cell sizes and extents -------------------------------------------------------------------

def test_a_non_finite_transform_is_refused() -> None:
    with pytest.raises(InputError, match="non-finite"):
        cell_size_metres("", Affine(float("nan"), 0, 0, 0, -30.0, 0), (10, 10), "x.tif")


def test_an_extent_that_overflows_is_refused() -> None:
    with pytest.raises(InputError, match="extent of x.tif is not finite"):
        cell_size_metres("", Affine(1e307, 0, 0, 0, -1e307, 0), (100, 100), "x.tif")


def test_geographic_rows_past_the_pole_are_refused() -> None:
    transform = Affine(0.01, 0, 10.0, 0, -0.01, 90.05)       # the top row starts 0.05° past 90°
    with pytest.raises(InputError, match="past the pole"):
        cell_size_metres(WGS84, transform, (20, 20), "polar.tif")


def test_geographic_rows_up_to_the_pole_are_kept() -> None:
    size = cell_size_metres(WGS84, Affine(0.01, 0, 10.0, 0, -0.01, 90.0), (20, 20), "polar.tif")
    assert math.isfinite(size.dx) and size.dx > 0 and size.dy > 1000.0


def test_a_raster_with_a_nan_cell_size_is_refused(folder: Path) -> None:
    write_geotiff(folder / "nancell.tif", np.ones((8, 8), np.float32),
                  transform=Affine(float("nan"), 0, 500000.0, 0, -30.0, 5000000.0))
    assert_refused(folder, "info", "nancell.tif", phrase="finite")
    assert_refused(folder, "convert", "nancell.tif", "out.tif", phrase="finite")


def test_a_geographic_raster_past_the_pole_is_refused_by_commands(folder: Path) -> None:
    write_geotiff(folder / "polar.tif", np.ones((20, 20), np.float32),
                  transform=Affine(0.01, 0, 10.0, 0, -0.01, 90.1), crs="EPSG:4326")
    assert_refused(folder, "info", "polar.tif", phrase="pole")
    assert_refused(folder, "convert", "polar.tif", "out.tif", phrase="pole")


# --- synth grids ------------------------------------------------------------------------------

@pytest.mark.parametrize("crs, centre, cell, phrase", [
    ("EPSG:32632", None, 1e308, "not finite"),
    ("EPSG:4326", (0.0, 89.99), 30.0, "pole"),
    ("EPSG:4326", (0.0, 95.0), 30.0, "globe"),
    ("EPSG:4326", (0.0, float("nan")), 30.0, "finite"),
    ("EPSG:4326", (0.0, 45.0), 1e7, "longitude"),
    ("EPSG:4326", (0.0, 88.0), 30_000.0, "pole"),
])
def test_centred_transform_refuses_grids_off_the_globe_or_past_double_precision(
        crs: str, centre: tuple[float, float] | None, cell: float, phrase: str) -> None:
    with pytest.raises(InputError, match=phrase):
        centred_transform(CRS.from_user_input(crs), (16, 16), cell, centre)


def test_centred_transform_keeps_ordinary_grids() -> None:
    transform = centred_transform(CRS.from_epsg(4326), (16, 16), 30.0, (10.0, 60.0))
    assert 0 < transform.a < 0.01 and transform.e < 0
    utm = centred_transform(CRS.from_epsg(32632), (16, 16), 30.0, (500000.0, 5000000.0))
    assert utm.a == 30.0 and utm.c == 500000.0 - 240.0


@pytest.mark.parametrize("args, phrase", [
    (("--dx", "1e308"), "not finite"),
    (("--crs", "EPSG:4326", "--centre", "0,89.99"), "pole"),
    (("--crs", "EPSG:4326", "--centre", "0,95"), "globe"),
], ids=["dx-1e308", "centre-at-the-pole", "centre-beyond-the-pole"])
def test_synth_refuses_non_finite_grids(tmp_path: Path, args: tuple[str, ...], phrase: str) -> None:
    assert_refused(tmp_path, "synth", "out.tif", "--size", "16", *args, phrase=phrase)


# --- convert ----------------------------------------------------------------------------------

@pytest.mark.parametrize("args, phrase", [
    (("--z-scale", "1e308"), "z-scale"),
    (("--z-scale", "inf"), "z-scale"),
    (("--z-scale", "1e37"), "float32"),
    (("--cell-size", "nan"), "cell-size"),
    (("--crop", "0,0,10,10"), "no cell"),
], ids=["z-scale-1e308", "z-scale-inf", "z-scale-past-float32", "cell-size-nan", "crop-outside"])
def test_convert_refuses_non_finite_results(folder: Path, args: tuple[str, ...], phrase: str) -> None:
    assert_refused(folder, "convert", "in.tif", "out.tif", *args, phrase=phrase)


def test_convert_z_scale_in_float64_range_is_kept(folder: Path) -> None:
    code, stderr = cli(folder, "convert", "in.tif", "out.tif", "--z-scale", "1e37", "--dtype", "float64")
    assert code == 0, stderr


def test_crop_window_and_resampled_shape() -> None:
    rows, cols = crop_window(UTM, (100, 100), (500000.0, 4999000.0, 501000.0, 5000000.0))
    assert (rows, cols) == (slice(0, 33), slice(0, 33))
    with pytest.raises(InputError, match="finite"):
        crop_window(UTM, (100, 100), (float("nan"), 0.0, 1.0, 1.0))
    assert resampled_shape(UTM, (100, 100), 60.0) == (50, 50)
    with pytest.raises(InputError, match="more cells than can be counted"):
        resampled_shape(UTM, (100, 100), 1e-300)
    with pytest.raises(InputError, match="--cell-size"):
        resampled_shape(UTM, (100, 100), float("nan"))


# --- a picture given as a DEM -----------------------------------------------------------------

def test_a_png_is_not_georeferenced(tmp_path: Path) -> None:
    picture = png(tmp_path / "pic.png")
    for read in (read_header, read_terrain):
        with pytest.raises(InputError, match="pic.png is not georeferenced"):
            read(picture)


@pytest.mark.parametrize("command", [("info", "pic.png"), ("convert", "pic.png", "out.tif"),
                                     ("flow", "pic.png", "q.tif")])
def test_commands_say_a_png_is_not_georeferenced(tmp_path: Path, command: tuple[str, ...]) -> None:
    png(tmp_path / "pic.png")
    said = assert_refused(tmp_path, *command, phrase="is not georeferenced")
    assert "gdal_translate" in said
