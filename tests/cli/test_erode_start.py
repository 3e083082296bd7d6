"""The start an erode/unerode run keeps (``jobs.erode.start``): float32 where that holds the
DEM read exactly, the float64 grid read then being the run's own; the change final − start
and the divergence guard's measure are those of the float64 start to the bit."""

from __future__ import annotations

import numpy as np

from unerode_cli.io.terrain import Terrain
from unerode_cli.jobs.erode.start import take_elevation
from unerode_cli.run.divergence import DivergenceGuard


def _terrain(values: np.ndarray) -> Terrain:
    values[3, 4] = np.nan       # a nodata cell
    return Terrain(values, 30.0, 30.0)


def test_a_dem_float32_holds_is_kept_in_float32_and_the_run_steps_the_grid_read() -> None:
    read = (500.0 + 100.0 * np.random.default_rng(1).random((20, 30))).astype(np.float32).astype(np.float64)
    terrain = _terrain(read)
    guard = DivergenceGuard(terrain.elevation)
    run = take_elevation(terrain, guard)
    assert run is read and run.dtype == np.float64
    assert terrain.elevation.dtype == np.float32
    np.testing.assert_array_equal(terrain.elevation.astype(np.float64), read.copy())
    assert guard.reference is terrain.elevation and guard.inside is terrain.grid.valid
    run += 0.125
    change = run - terrain.elevation
    assert change.dtype == np.float64
    assert np.array_equal(change[terrain.grid.valid], np.full(599, 0.125))
    guard.check(run, 0.0, "after a step")      # a sane change passes


def test_a_dem_float32_does_not_hold_keeps_its_float64_start() -> None:
    read = 500.0 + 100.0 * np.random.default_rng(2).random((20, 30))
    terrain = _terrain(read)
    guard = DivergenceGuard(terrain.elevation)
    run = take_elevation(terrain, guard)
    assert terrain.elevation is read and guard.reference is read
    assert run is not read and run.dtype == np.float64
    np.testing.assert_array_equal(run, read)
