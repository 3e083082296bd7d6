"""CF-1.8 NetCDF outputs read back with xarray (and GDAL): the snapshot time series of
``--snapshots-nc`` (time and age axes, cell-centre coordinates, the CRS as a grid mapping, units
on every variable, the GeoTIFF snapshots' values) and the named variable of a single ``.nc``
raster."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import rasterio
from affine import Affine
from pyproj import CRS
from rasterio.crs import CRS as RioCRS

from unerode_cli.io.gdal_io import WriteOptions
from unerode_cli.io.netcdf_files import AGE_TAG, TIME_TAG, write_series
from unerode_cli.io.rasters import write_terrain
from unerode_cli.io.terrain import Terrain

xr = pytest.importorskip("xarray")

UTM = "EPSG:32632"


def _snapshots(folder: Path, crs: str, transform: Affine, ages: list[float]) -> list[Path]:
    """GeoTIFF snapshots (5 × 7 cells, one nodata cell) tagged with their ages (ka) and times (y),
    written oldest last, so that the series must reorder them."""
    paths = []
    rows, cols = 5, 7
    for k, age in enumerate(ages):
        z = 100.0 + 10.0 * k + np.arange(rows * cols, dtype=np.float64).reshape(rows, cols) / 7.0
        z[1, 2] = np.nan
        tags = {AGE_TAG: repr(age), TIME_TAG: repr(-1000.0 * age)}
        terrain = Terrain(z, 30.0, 30.0, RioCRS.from_user_input(crs).to_wkt(), transform, None, tags)
        path = folder / f"snap_{k}.tif"
        write_terrain(terrain, path)
        paths.append(path)
    return paths


def _centres(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """x of the column centres and y of the row centres, as rasterio gives them."""
    with rasterio.open(path) as src:
        xs = np.array([src.xy(0, c)[0] for c in range(src.width)])
        ys = np.array([src.xy(r, 0)[1] for r in range(src.height)])
    return xs, ys


def test_series_has_the_ages_the_centres_the_crs_and_the_values(tmp_path: Path) -> None:
    transform = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
    ages = [2.0, 10.0, 5.0]
    paths = _snapshots(tmp_path, UTM, transform, ages)
    nc = tmp_path / "series.nc"
    write_series(nc, paths)
    with xr.open_dataset(nc) as ds:
        # the time axis: years relative to the present, increasing; age (kyr) along it
        np.testing.assert_allclose(ds["time"].values, [-10000.0, -5000.0, -2000.0])
        np.testing.assert_allclose(ds["age"].values, [10.0, 5.0, 2.0])
        assert ds["time"].attrs["axis"] == "T" and ds["time"].attrs["units"] == "year"
        assert ds["age"].attrs["units"] == "kyr"
        xs, ys = _centres(paths[0])
        np.testing.assert_allclose(ds["x"].values, xs, rtol=0, atol=1e-6)
        np.testing.assert_allclose(ds["y"].values, ys, rtol=0, atol=1e-6)
        assert ds["x"].attrs["standard_name"] == "projection_x_coordinate"
        mapping = ds["crs"].attrs
        assert CRS.from_wkt(mapping["crs_wkt"]) == CRS.from_user_input(UTM)
        assert CRS.from_cf(mapping) == CRS.from_user_input(UTM)
        assert mapping["grid_mapping_name"] == "transverse_mercator"
        assert ds["elevation"].attrs["grid_mapping"] == "crs"
        for name in ("time", "age", "x", "y", "elevation"):
            assert ds[name].attrs.get("units"), f"{name} has no units"
            assert ds[name].attrs.get("long_name") or ds[name].attrs.get("standard_name")
        assert ds["elevation"].attrs["units"] == "m"
        assert ds["elevation"].attrs["standard_name"] == "surface_altitude"
        assert ds.attrs["Conventions"] == "CF-1.8"
        assert ds["elevation"].encoding["zlib"] and ds["elevation"].encoding["_FillValue"] == -9999.0
        by_age = dict(zip(ages, paths, strict=True))
        for k, age in enumerate(ds["age"].values):
            with rasterio.open(by_age[float(age)]) as src:
                expected = src.read(1, masked=True).filled(np.nan)
            np.testing.assert_array_equal(ds["elevation"].values[k], expected)   # NaN where nodata


def test_gdal_reads_the_series_with_its_crs_and_grid(tmp_path: Path) -> None:
    transform = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
    paths = _snapshots(tmp_path, UTM, transform, [1.0, 3.0])
    nc = tmp_path / "series.nc"
    write_series(nc, paths)
    with rasterio.open(f"netcdf:{nc}:elevation") as src:
        assert src.count == 2 and src.crs == RioCRS.from_user_input(UTM)
        assert src.transform.almost_equals(transform)
        assert src.nodata == -9999.0


def test_geographic_series_has_lon_lat(tmp_path: Path) -> None:
    transform = Affine(0.001, 0.0, 8.0, 0.0, -0.001, 46.0)
    paths = _snapshots(tmp_path, "EPSG:4326", transform, [1.0])
    nc = tmp_path / "series.nc"
    write_series(nc, paths)
    with xr.open_dataset(nc) as ds:
        assert ds["elevation"].dims == ("time", "lat", "lon")
        assert ds["lon"].attrs["units"] == "degrees_east" and ds["lat"].attrs["units"] == "degrees_north"
        np.testing.assert_allclose(ds["lon"].values, 8.0 + 0.001 * (np.arange(7) + 0.5))
        np.testing.assert_allclose(ds["lat"].values, 46.0 - 0.001 * (np.arange(5) + 0.5))
        assert CRS.from_wkt(ds["crs"].attrs["crs_wkt"]) == CRS.from_epsg(4326)


def test_single_nc_raster_has_a_named_variable_with_units(tmp_path: Path) -> None:
    z = np.arange(12, dtype=np.float64).reshape(3, 4) + 250.0
    z[0, 0] = np.nan
    transform = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
    terrain = Terrain(z, 30.0, 30.0, RioCRS.from_user_input(UTM).to_wkt(), transform)
    nc = tmp_path / "dem.nc"
    write_terrain(terrain, nc, WriteOptions())
    with xr.open_dataset(nc) as ds:
        assert "Band1" not in ds.variables
        assert ds["elevation"].attrs["units"] == "m"
        assert ds["elevation"].attrs["standard_name"] == "surface_altitude"
        north_up = ds["elevation"].sortby("y", ascending=False)     # GDAL writes rows bottom-up
        np.testing.assert_array_equal(north_up.values, z.astype(np.float32))
        np.testing.assert_allclose(north_up["y"].values, 5000000.0 - 30.0 * (np.arange(3) + 0.5))
    discharge = Terrain(z, 30.0, 30.0, terrain.crs_wkt, transform, tags={"UNIT": "m3/y"})
    write_terrain(discharge, tmp_path / "q.nc", WriteOptions())
    with xr.open_dataset(tmp_path / "q.nc") as ds:
        assert ds["value"].attrs["units"] == "m3/y"
    with rasterio.open(nc) as src:       # GDAL still reads it, CRS and grid included
        assert src.crs == RioCRS.from_user_input(UTM) and src.transform.almost_equals(transform)


def test_erode_writes_its_snapshots_as_one_netcdf(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from unerode_cli.cli.app import app

    rows, cols = 16, 16
    z = 100.0 + np.add.outer(np.arange(rows)[::-1] * 3.0, np.sin(np.arange(cols)))
    transform = Affine(30.0, 0.0, 500000.0, 0.0, -30.0, 5000000.0)
    with rasterio.open(tmp_path / "in.tif", "w", driver="GTiff", height=rows, width=cols, count=1,
                       dtype="float32", crs=UTM, transform=transform) as dst:
        dst.write(z.astype(np.float32), 1)
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        result = CliRunner().invoke(app, ["erode", "in.tif", "out.tif", "--dt", "100", "--steps", "4",
                                          "--snapshot-every", "200", "--snapshots-nc", "s.nc"])
    finally:
        os.chdir(cwd)
    assert result.exit_code == 0, result.output
    with xr.open_dataset(tmp_path / "s.nc") as ds:
        np.testing.assert_allclose(ds["time"].values, [200.0, 400.0])
        assert "age" not in ds.variables
        for k, name in enumerate(("out_001.tif", "out_002.tif")):
            with rasterio.open(tmp_path / name) as src:
                np.testing.assert_array_equal(ds["elevation"].values[k], src.read(1))
                assert CRS.from_wkt(ds["crs"].attrs["crs_wkt"]) == CRS.from_user_input(src.crs.to_wkt())
