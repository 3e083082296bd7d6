"""The Python API (unerode_cli.api): its examples run, and its numbers are the command line's,
bit for bit, for erode, unerode and glaciate."""

from __future__ import annotations

import doctest
from pathlib import Path

import numpy as np
import pytest
import rasterio

import unerode_cli
from tests.conftest import SAMPLE_DEMS, run_cli, write_geotiff
from unerode_cli import api

ROOT = Path(__file__).resolve().parents[1]


def test_the_api_examples_run(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)            # the examples read sample_dems/
    result = doctest.testmod(api, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 20
    assert result.failed == 0


def test_the_api_is_offered_at_the_top_level() -> None:
    assert unerode_cli.erode is api.erode
    assert set(unerode_cli.API) <= set(dir(unerode_cli))


def _cli_result(tmp_path: Path, command: str, dem: Path, *options: object, extra: str = "") -> np.ndarray:
    out = tmp_path / f"{command}_cli.tif"
    args = [command, dem, out, "--dtype", "float64", *options]
    if extra:
        args += ["--ice", tmp_path / extra]
    result = run_cli(*args)
    assert result.returncode == 0, result.stderr
    with rasterio.open(out) as src:
        return src.read(1)


def _float64_dem(tmp_path: Path) -> tuple[Path, np.ndarray]:
    with rasterio.open(SAMPLE_DEMS / "valley_utm32n_30m.tif") as src:
        data = src.read(1).astype(np.float64)[:96, :96]
        transform = src.transform
    return write_geotiff(tmp_path / "dem64.tif", data, transform=transform), data


@pytest.mark.parametrize("command", ["erode", "unerode"])
def test_erode_and_unerode_give_the_command_lines_numbers(tmp_path: Path, command: str) -> None:
    dem, data = _float64_dem(tmp_path)
    options = {"process": "fluvial,thermal", "dt": 500.0, "steps": 3, "K": 2e-5, "K_d": 1.0,
               "k_th": 0.002, "outlets": "S"}
    cli = _cli_result(tmp_path, command, dem, "--process", "fluvial,thermal", "--dt", 500, "--steps", 3,
                      "--K", 2e-5, "--K-d", 1, "--k-th", 0.002, "--outlets", "S")
    from_array = getattr(api, command)(data, cell_size=30.0, crs="EPSG:32632", **options)
    from_terrain = getattr(api, command)(api.read(dem), **options)
    assert np.array_equal(from_array, cli, equal_nan=True)
    assert np.array_equal(from_terrain.elevation, cli, equal_nan=True)
    assert np.nanmax(np.abs(cli - data)) > 0.01          # the run did change the terrain


def test_glaciate_gives_the_command_lines_numbers(tmp_path: Path) -> None:
    y, x = np.mgrid[0:24, 0:24] * 100.0
    mountain = 3000.0 - 0.05 * np.hypot(x - 1150.0, y - 1150.0)
    dem = write_geotiff(tmp_path / "mountain.tif", mountain,
                        transform=rasterio.Affine(100.0, 0, 0, 0, -100.0, 2400.0))
    bed_cli = _cli_result(tmp_path, "glaciate", dem, "--ela", 2900, "--duration", 60, "--dt", 10,
                          extra="ice_cli.tif")
    with rasterio.open(tmp_path / "ice_cli.tif") as src:
        ice_cli = src.read(1)
    bed, ice = api.glaciate(mountain, cell_size=100.0, crs="EPSG:32632", ela=2900.0, duration=60, dt=10)
    assert ice_cli.max() > 1.0                              # glaciers grew
    assert np.array_equal(bed, bed_cli) and np.array_equal(ice, ice_cli)


def test_bad_options_are_one_sentence() -> None:
    with pytest.raises(api.InputError, match="has no option wobble"):
        api.erode(np.zeros((4, 4)), cell_size=10.0, wobble=1)
    with pytest.raises(api.InputError, match="--dt: must be > 0 years"):
        api.erode(np.zeros((4, 4)), cell_size=10.0, dt=-5, steps=1)
    with pytest.raises(api.InputError, match="cell_size"):
        api.erode(np.zeros((4, 4)), dt=5, steps=1)


def test_an_array_parameter_is_a_raster_on_the_grid(tmp_path: Path) -> None:
    dem, data = _float64_dem(tmp_path)
    k = np.full(data.shape, 2e-5)
    k[:, :48] = 0.0                                          # the west half does not erode
    eroded = api.erode(data, cell_size=30.0, dt=500.0, steps=2, K=k, outlets="S")
    change = eroded - data
    assert np.nanmax(np.abs(change[:, :40])) < np.nanmax(np.abs(change[:, 56:]))


def test_a_dataarray_keeps_its_coordinates_and_crs(tmp_path: Path) -> None:
    rioxarray = pytest.importorskip("rioxarray")
    dem, data = _float64_dem(tmp_path)
    grid = rioxarray.open_rasterio(dem).squeeze("band", drop=True)
    eroded = api.erode(grid, dt=500.0, steps=2, K=2e-5)
    assert eroded.rio.crs == grid.rio.crs and eroded.rio.transform() == grid.rio.transform()
    assert np.array_equal(eroded.x, grid.x) and np.array_equal(eroded.y, grid.y)
    cli = _cli_result(tmp_path, "erode", dem, "--dt", 500, "--steps", 2, "--K", 2e-5)
    assert np.array_equal(eroded.values, cli, equal_nan=True)
