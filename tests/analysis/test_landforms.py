"""Landform measures (001 §7.1, Fig. 15) on valleys whose answer is known: parabolic and
V-shaped troughs at an angle to the grid, a tributary hanging 40 m above its trunk, dug basins,
a squeezed hypsometry, and a real lake (Bachalpsee) on the Grindelwald DEM."""

from __future__ import annotations

import numpy as np
import pytest
from tests.conftest import SHARED_DATA

from unerode_cli.analysis.landforms import (
    Settings,
    fit_power_law,
    hanging_steps,
    hypsometry_shift,
    lakes,
    measure_landforms,
    u_shape_index,
)
from unerode_cli.analysis.river import auto_river
from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask

DX = 30.0
GRINDELWALD = SHARED_DATA / "dem" / "alps_grindelwald" / "dem.tif"


def trough(profile, angle_deg: float = 30.0, shape: tuple[int, int] = (80, 80), slope: float = 0.03,
           noise: float = 1.0) -> np.ndarray:
    """A straight valley through the middle of the grid, its axis turned ``angle_deg`` from
    north-south, rising ``slope`` (m/m) along the axis, with the cross profile ``profile``
    (m, of the distance across in m) and ``noise`` m of white noise."""
    rows, cols = np.indices(shape, dtype=np.float64)
    east, south = (cols - shape[1] / 2) * DX, (rows - shape[0] / 2) * DX
    turn = np.radians(angle_deg)
    along = east * np.sin(turn) + south * np.cos(turn)
    across = east * np.cos(turn) - south * np.sin(turn)
    return 500.0 + slope * along + profile(across) + noise * np.random.default_rng(1).standard_normal(shape)


def measured(z: np.ndarray, **settings: float):
    grid = Grid.full(z.shape, DX)
    return measure_landforms(z, grid, outlet_mask(grid), settings=Settings(**settings))


SECTIONS = {"spacing_m": 300.0, "half_width_m": 900.0}


def test_fit_power_law_recovers_an_off_centre_origin() -> None:
    x = np.arange(-600.0, 601.0, 30.0)
    z = 812.0 + 0.003 * np.abs(x - 37.0) ** 1.7
    b, a, x0, z0, rmse = fit_power_law(x, z)
    assert b == pytest.approx(1.7, abs=1e-4)
    assert a == pytest.approx(0.003, rel=1e-3)
    assert x0 == pytest.approx(37.0, abs=0.05)
    assert z0 == pytest.approx(812.0, abs=0.01)
    assert rmse < 1e-3


def test_a_parabolic_trough_is_u_shaped() -> None:
    result = measured(trough(lambda x: 5e-4 * x**2), **SECTIONS)
    assert len(result.u_shape.sections) >= 6
    assert result.u_shape.median_b == pytest.approx(2.0, abs=0.2)
    assert np.all(np.abs(result.u_shape.exponents - 2.0) < 0.3)


def test_a_v_shaped_valley_has_an_exponent_of_one() -> None:
    result = measured(trough(lambda x: 0.5 * np.abs(x)), **SECTIONS)
    assert len(result.u_shape.sections) >= 6
    assert result.u_shape.median_b == pytest.approx(1.0, abs=0.2)
    assert np.all(np.abs(result.u_shape.exponents - 1.0) < 0.3)


def test_sections_of_a_flat_plain_are_not_fitted() -> None:
    z = trough(lambda x: 0.0 * x, noise=0.5)
    grid = Grid.full(z.shape, DX)
    river = auto_river(z, grid, outlet_mask(grid))
    shape = u_shape_index(z, grid, river, Settings(**SECTIONS))
    assert shape.sections == () and np.isnan(shape.median_b)


def hanging_valley(lip: float) -> np.ndarray:
    """A V-shaped trunk along column 30 (walls 0.5 m/m, floor rising 0.02 m/m to the south) and
    a tributary valley from the east joining it at row 30, its floor rising 0.02 m/m east and
    ``lip`` m above the trunk floor where it meets the trunk's wall (walls 0.3 m/m)."""
    rows, cols = np.indices((80, 61), dtype=np.float64)
    x, y = (cols - 30) * DX, (rows - 30) * DX
    floor = 500.0 + 0.02 * rows * DX
    trunk = floor + 0.5 * np.abs(x)
    wall = lip / 0.5  # where the tributary floor meets the trunk's wall (m east of the axis)
    tributary = 500.0 + 0.02 * 30 * DX + lip + 0.02 * (x - wall) + 0.3 * np.abs(y)
    return np.minimum(trunk, np.where(x > 0.0, tributary, np.inf))


def test_a_tributary_hanging_40_m_above_the_trunk_has_a_40_m_step() -> None:
    """The tributary drops 40 m down the trunk's wall and 0.02 m/m on its own floor; over the
    250 m reach (8 cells of 30 m: 240 m) the trunk's gradient gives 0.02 × 240 = 4.8 m, its
    floor 0.02 × (240 − 80) = 3.2 m: step 40 − 1.6 = 38.4 m."""
    z = hanging_valley(40.0)
    grid = Grid.full(z.shape, DX)
    outlets = outlet_mask(grid)
    result = hanging_steps(z, grid, outlets, auto_river(z, grid, outlets), Settings(reach_m=250.0))
    assert len(result.junctions) == 1
    junction = result.junctions[0]
    assert (junction.row, junction.col) == (30, 30)
    assert junction.trunk_gradient == pytest.approx(0.02, rel=1e-6)
    assert junction.step_m == pytest.approx(40.0, abs=5.0)
    assert len(result.hanging) == 1


def test_a_graded_tributary_has_no_step() -> None:
    z = hanging_valley(0.0)
    grid = Grid.full(z.shape, DX)
    outlets = outlet_mask(grid)
    result = hanging_steps(z, grid, outlets, auto_river(z, grid, outlets), Settings(reach_m=250.0))
    assert len(result.junctions) == 1
    assert abs(result.junctions[0].step_m) < 2.0
    assert result.hanging == ()


def test_two_dug_basins_are_two_lakes() -> None:
    z = trough(lambda x: 5e-4 * x**2, angle_deg=0.0, noise=0.0)
    z[20:24, 39:42] -= 10.0
    z[55:58, 38:43] -= 6.0
    grid = Grid.full(z.shape, DX)
    depth, stats = lakes(z, grid, outlet_mask(grid))
    assert stats.count == 2
    assert stats.area_m2 == pytest.approx((12 + 15) * DX * DX)
    # each spills over the axis cell just north of it: 0.03 m/m × 30 m less than the dug rows
    assert depth[20:24, 39:42].max() == pytest.approx(10.0 - 0.03 * DX * 1, abs=1e-6)
    assert lakes(z, grid, outlet_mask(grid), min_depth=8.0)[1].count == 1


def test_the_hypsometric_maximum_moves_to_where_the_area_piles_up() -> None:
    """A cone (the most area at its foot) whose upper part is planed down into a band just above
    600 m, as a glacial buzzsaw does near the ELA: the maximum moves from the foot to 600 m."""
    rows, cols = np.indices((101, 101), dtype=np.float64)
    radius = np.hypot(rows - 50, cols - 50)
    before = np.where(radius <= 50.0, 1000.0 - 20.0 * radius, np.nan)
    after = np.where(before > 600.0, 600.0 + 0.05 * (before - 600.0), before)
    shift = hypsometry_shift(after, before, bins=50)
    assert shift.before.mode_m < 100.0
    assert 600.0 <= shift.after.mode_m <= 625.0
    assert shift.mode_shift_m > 500.0
    assert shift.mean_shift_m < 0.0
    assert np.isnan(hypsometry_shift(after).mode_shift_m)


def test_bad_settings_are_refused() -> None:
    z = trough(lambda x: 5e-4 * x**2)
    with pytest.raises(ValueError, match="spacing_m"):
        measured(z, spacing_m=0.0)
    with pytest.raises(ValueError, match="tributary_fraction"):
        measured(z, tributary_fraction=1.5)


@pytest.mark.skipif(not GRINDELWALD.exists(), reason="needs ../shared/data/dem")
def test_bachalpsee_is_found_at_its_level() -> None:
    """Bachalpsee, the lake above Grindelwald (surface 2265 m, about 8 ha), is in the north-west
    corner of the Grindelwald DEM: the largest lake of that corner, at its level."""
    from unerode_cli.hydro.depressions import lake_labels
    from unerode_cli.io.rasters import read_terrain

    z = read_terrain(GRINDELWALD).elevation[:70, :70]
    grid = Grid.full(z.shape, 46.0)
    depth, stats = lakes(z, grid, outlet_mask(grid))
    labels, count = lake_labels(depth)
    largest = np.argmax(np.bincount(labels.ravel())[1:]) + 1
    level = (z + depth)[labels == largest]
    assert np.ptp(level) < 1e-6
    assert level[0] == pytest.approx(2265.0, abs=5.0)
    assert 3e4 < stats.largest_area_m2 < 1.2e5
