"""Previews of large rasters: block decimation (mean, max, nodata), its factor, and the memory
that save_preview takes on a large heightfield."""

from __future__ import annotations

import tracemalloc
import warnings
from pathlib import Path

import matplotlib.image
import matplotlib.pyplot
import numpy as np
import pytest

from unerode_cli.viz.preview import decimate, preview_factor, save_field_preview, save_preview


def _blocks_reference(values: np.ndarray, factor: int) -> np.ndarray:
    """The raster padded with NaN to whole blocks, as (block row, row in block, block column,
    column in block)."""
    ny, nx = values.shape
    my, mx = -(-ny // factor), -(-nx // factor)
    padded = np.full((my * factor, mx * factor), np.nan)
    padded[:ny, :nx] = values
    return padded.reshape(my, factor, mx, factor)


def _random_with_nan(shape: tuple[int, int], seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    values = rng.normal(100.0, 40.0, shape)
    values[rng.random(shape) < 0.3] = np.nan
    values[:5, :5] = np.nan  # at least one whole block of nodata for factors up to 5
    return values


@pytest.mark.parametrize("factor", [2, 3, 5])
def test_mean_and_max_match_a_direct_numpy_reference(factor: int) -> None:
    values = _random_with_nan((53, 38))  # divisible by none of the factors
    blocks = _blocks_reference(values, factor)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mean = np.nanmean(blocks, axis=(1, 3))
        largest = np.nanmax(blocks, axis=(1, 3))
    shape = (-(-53 // factor), -(-38 // factor))
    got_mean, got_max = decimate(values, factor, "mean"), decimate(values, factor, "max")
    assert got_mean.shape == got_max.shape == shape
    np.testing.assert_allclose(got_mean, mean, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got_max, largest)  # NaN at the same places, values equal
    assert np.isnan(got_mean[0, 0]) and np.isnan(got_max[0, 0])  # the all-NaN corner block


def test_an_all_nan_block_gives_nan_without_a_warning() -> None:
    values = np.arange(36.0).reshape(6, 6)
    values[2:4, 4:6] = np.nan
    values[4:6, 0] = np.nan  # half a block of nodata: the other half's mean/max
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mean, largest = decimate(values, 2, "mean"), decimate(values, 2, "max")
    assert np.isnan(mean[1, 2]) and np.isnan(largest[1, 2])
    assert np.isfinite(mean).sum() == np.isfinite(largest).sum() == 8
    assert mean[2, 0] == (25.0 + 31.0) / 2 and largest[2, 0] == 31.0
    assert mean[0, 0] == (0.0 + 1.0 + 6.0 + 7.0) / 4 and largest[0, 0] == 7.0


def test_nodata_from_masks_the_cells_of_another_raster() -> None:
    values = np.ones((4, 4))
    values[0, 0] = 10.0
    elevation = np.zeros((4, 4))
    elevation[0, 0] = np.nan
    np.testing.assert_array_equal(decimate(values, 2, "max", nodata_from=elevation), np.ones((2, 2)))
    elevation[:2, :2] = np.nan
    assert np.isnan(decimate(values, 2, "mean", nodata_from=elevation)[0, 0])


def test_factor_one_returns_the_input_itself() -> None:
    values = _random_with_nan((7, 9))
    assert decimate(values, 1, "mean") is values


def test_the_factor_keeps_both_sides_within_the_cell_budget() -> None:
    assert preview_factor((100, 100)) == 1
    assert preview_factor((2048, 2048)) == 1
    assert preview_factor((2049, 10)) == 2
    assert preview_factor((10, 4097)) == 3
    assert preview_factor((16384, 16384)) == 8
    assert preview_factor((300, 200), max_cells=100) == 3


def test_a_one_cell_river_survives_max_decimation() -> None:
    field = np.ones((5000, 300))
    field[:, 157] = 1e9  # a river one cell wide, running north-south
    factor = preview_factor(field.shape)
    assert factor == 3
    largest = decimate(field, factor, "max")
    assert largest.shape == (1667, 100)
    np.testing.assert_array_equal(largest[:, 157 // factor], 1e9)
    assert np.all(np.delete(largest, 157 // factor, axis=1) == 1.0)
    # a mean would dilute it ninefold (a block is 3 × 3 cells, the river one column of them)
    assert decimate(field, factor, "mean")[0, 157 // factor] == pytest.approx((1e9 + 2.0) / 3)


def test_save_preview_of_a_large_plane_stays_within_three_times_its_input(tmp_path: Path) -> None:
    n, dx = 6000, 25.0
    plane = np.add.outer(np.linspace(0.0, 300.0, n), np.linspace(0.0, 600.0, n))  # 288 MB
    path = tmp_path / "plane.png"
    tracemalloc.start()
    try:
        save_preview(plane, dx, dx, path, title="plane")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 3 * plane.nbytes, f"peak {peak / 1e6:.0f} MB for a {plane.nbytes / 1e6:.0f} MB input"
    image = matplotlib.image.imread(path)
    assert image.ndim == 3 and image.shape[1] == round(7.0 * 110)


def test_field_preview_of_a_large_raster_keeps_its_extent_and_its_river(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    elevation = np.add.outer(np.linspace(0.0, 50.0, 4100), np.zeros(200))
    elevation[:40, :40] = np.nan
    discharge = np.ones_like(elevation)
    discharge[:, 100] = 1e6
    figures = []
    monkeypatch.setattr(matplotlib.pyplot, "close", figures.append)  # keep the figure to read it
    path = tmp_path / "discharge.png"
    save_field_preview(discharge, elevation, 30.0, 30.0, path, "discharge (m³/y)", log=True)
    assert matplotlib.image.imread(path).shape[1] == round(7.0 * 110)
    shade, colours = figures[0].axes[0].get_images()
    for image in (shade, colours):
        assert image.get_extent() == pytest.approx((0.0, 200 * 0.03, 0.0, 4100 * 0.03))  # km
        assert image.get_array().shape == (1367, 67)  # factor 3
    log_discharge = np.ma.filled(colours.get_array(), np.nan)
    np.testing.assert_array_equal(log_discharge[14:, 100 // 3], 6.0)
    assert np.all(np.isnan(log_discharge[:13, :13]))  # blocks with no elevation
    matplotlib.pyplot.close(figures[0])
