"""Lakes in the depressions of bed + ice (001 §7): volumes against spill levels worked out by
hand on an over-deepened trough, ice that fills or dams the hollow, basins that drain off the
map, and nodata."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.glacier.lakes import ICE_FREE_BELOW, lake_depth, lake_stats
from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask
from unerode_cli.hydro.depressions import fill_depressions

DX = 10.0
CELL = DX * DX
BASIN = (slice(10, 15), slice(9, 12))  # rows 10–14, columns 9–11: 15 cells dug 8 m deep


def trough() -> np.ndarray:
    """A U-shaped trough along the columns, axis on column 10, floor rising 0.5 m per row to
    the south: z = 100 + 0.5 r + 0.5 (c − 10)² (m), on 30 × 21 cells of 10 m; an
    over-deepening dug 8 m into its floor (rows 10–14, columns 9–11)."""
    rows, cols = np.indices((30, 21), dtype=np.float64)
    z = 100.0 + 0.5 * rows + 0.5 * (cols - 10.0) ** 2
    z[BASIN] -= 8.0
    return z


# The hollow spills over the lowest cell of its rim: the trough axis just downstream (north) of
# it, row 9, column 10, at 100 + 0.5·9 = 104.5 m; the rim cells beside it stand at 105 m (row 9,
# columns 9 and 11) and more, the rim upstream at 107.5 m (row 15).
SPILL = 104.5


def hand_volume(z: np.ndarray) -> float:
    """Σ (spill − z) × cell area over the dug cells, all of them below the spill level."""
    assert (z[BASIN] < SPILL).all()
    return float((SPILL - z[BASIN]).sum() * CELL)


def test_an_over_deepened_trough_holds_a_lake_up_to_its_spill_level() -> None:
    z = trough()
    grid = Grid.full(z.shape, DX)
    depth = lake_depth(z, np.zeros_like(z), grid, outlet_mask(grid))
    assert depth[BASIN].sum() * CELL == pytest.approx(hand_volume(z), rel=1e-6)
    np.testing.assert_allclose(depth[BASIN], SPILL - z[BASIN], rtol=0, atol=1e-9)
    outside = np.ones(z.shape, dtype=bool)
    outside[BASIN] = False
    assert (depth[outside] == 0.0).all()
    stats = lake_stats(depth, grid)
    assert stats.count == 1
    assert stats.area_m2 == pytest.approx(15 * CELL)
    assert stats.largest_area_m2 == pytest.approx(15 * CELL)
    assert stats.volume_m3 == pytest.approx(hand_volume(z), rel=1e-6)
    assert stats.max_depth_m == pytest.approx(SPILL - (100.0 + 0.5 * 10 - 8.0))  # row 10 on the axis: 7.5 m
    # the spill surface itself: flat at 104.5 m over the lake, the terrain elsewhere
    filled = fill_depressions(z, grid, outlet_mask(grid))
    assert (filled[BASIN] == SPILL).all()
    np.testing.assert_array_equal(filled[outside], z[outside])


def test_ice_that_fills_the_basin_leaves_no_lake() -> None:
    z = trough()
    grid = Grid.full(z.shape, DX)
    ice = np.zeros_like(z)
    ice[BASIN] = 106.0 - z[BASIN]  # a flat ice surface at 106 m, above the spill level
    depth = lake_depth(z, ice, grid, outlet_mask(grid))
    assert (depth == 0.0).all()
    assert lake_stats(depth, grid).count == 0


def test_cells_under_ice_hold_no_water_and_ice_thinner_than_the_threshold_is_free() -> None:
    z = trough()
    grid = Grid.full(z.shape, DX)
    ice = np.zeros_like(z)
    ice[10:12, 9:12] = 3.0  # a glacier tongue in the north half of the hollow, surface below 104.5 m
    ice[13:15, 9:12] = 0.5 * ICE_FREE_BELOW  # lake ice: still a lake
    depth = lake_depth(z, ice, grid, outlet_mask(grid))
    assert (depth[10:12, 9:12] == 0.0).all()
    s = z + ice
    np.testing.assert_allclose(depth[12:15, 9:12], SPILL - s[12:15, 9:12], atol=1e-9)
    assert lake_stats(depth, grid).volume_m3 == pytest.approx((SPILL - s[12:15, 9:12]).sum() * CELL, rel=1e-9)


def test_an_ice_dam_raises_the_lake_to_the_ice_surface() -> None:
    """Ice across the trough just downstream of the hollow (rows 7–9), its surface at 110 m:
    the lowest way out is now over the ice (the trough rises to 114.5 m at the south edge and
    its walls higher), so the water stands at 110 m over every ice-free cell below it from row
    10 up the trough to row 19 (100 + 0.5·19 = 109.5 m on the axis)."""
    z = trough()
    grid = Grid.full(z.shape, DX)
    ice = np.zeros_like(z)
    ice[7:10, :] = np.maximum(110.0 - z[7:10, :], 0.0)
    depth = lake_depth(z, ice, grid, outlet_mask(grid))
    level = 110.0
    rows = np.indices(z.shape)[0]
    expected = np.where((rows >= 10) & (z < level), level - z, 0.0)
    np.testing.assert_allclose(depth, expected, rtol=0, atol=1e-9)
    assert lake_stats(depth, grid).volume_m3 == pytest.approx(expected.sum() * CELL, rel=1e-9)


def test_a_basin_that_reaches_the_map_edge_drains_off_it() -> None:
    z = trough()
    z[BASIN] += 8.0
    z[0:4, 9:12] -= 8.0  # dug at the north edge, an outlet
    grid = Grid.full(z.shape, DX)
    depth = lake_depth(z, np.zeros_like(z), grid, outlet_mask(grid))
    assert (depth == 0.0).all()
    # closed on that edge (the other three still drain), the same hollow holds water
    closed = lake_depth(z, np.zeros_like(z), grid, outlet_mask(grid, "E,S,W"))
    assert closed.sum() > 0.0


def test_nodata_cells_hold_no_water_and_their_borders_drain() -> None:
    z = trough()
    valid = np.ones(z.shape, dtype=bool)
    valid[20:24, 2:5] = False  # a void far from the hollow: the lake is unchanged
    z_void = np.where(valid, z, np.nan)
    grid = Grid(DX, DX, valid)
    depth = lake_depth(z_void, np.where(valid, 0.0, np.nan), grid, outlet_mask(grid))
    assert depth.sum() * CELL == pytest.approx(hand_volume(z), rel=1e-6)
    assert (depth[~valid] == 0.0).all() and np.isfinite(depth).all()
    # a void at the deepest cell of the hollow: its border is an outlet, the hollow drains into it
    valid[10, 10] = False
    grid = Grid(DX, DX, valid)
    depth = lake_depth(np.where(valid, z, np.nan), np.zeros(z.shape), grid, outlet_mask(grid))
    assert (depth == 0.0).all()
    # the same void as a wall (nodata borders not outlets): water never enters it
    walled = lake_depth(np.where(valid, z, np.nan), np.zeros(z.shape), grid,
                        outlet_mask(grid, nodata_borders=False))
    lake = np.zeros(z.shape, dtype=bool)
    lake[BASIN] = True
    lake &= valid
    assert walled.sum() * CELL == pytest.approx(((SPILL - z) * lake).sum() * CELL, rel=1e-9)
    assert walled[10, 10] == 0.0


def test_lake_stats_counts_connected_lakes_and_skips_shallow_pits() -> None:
    grid = Grid.full((12, 12), 5.0)
    depth = np.zeros((12, 12))
    depth[1:3, 1:4] = 2.0  # lake 1: 6 cells
    depth[3, 4] = 1.0  # diagonal neighbour of (2, 3): the same lake (8 neighbours)
    depth[7:10, 7:10] = 0.6  # lake 2: 9 cells, deeper than 0.5 m
    depth[5, 9] = 0.3  # a pit shallower than the minimum depth
    stats = lake_stats(depth, grid)
    assert stats.count == 2
    assert stats.area_m2 == pytest.approx(16 * 25.0)
    assert stats.largest_area_m2 == pytest.approx(9 * 25.0)
    assert stats.volume_m3 == pytest.approx((6 * 2.0 + 1.0 + 9 * 0.6) * 25.0)
    assert lake_stats(depth, grid, min_depth=0.0).count == 3
    assert lake_stats(depth, grid, min_depth=1.5).count == 1


def test_bad_ice_is_refused() -> None:
    z = trough()
    grid = Grid.full(z.shape, DX)
    with pytest.raises(ValueError, match="≥ 0 m"):
        lake_depth(z, np.full(z.shape, -1.0), grid, outlet_mask(grid))
    with pytest.raises(ValueError, match="shape"):
        lake_depth(z, np.zeros((3, 3)), grid, outlet_mask(grid))
    with pytest.raises(ValueError, match="no outlet"):
        lake_depth(z, np.zeros(z.shape), grid, outlet_mask(grid, "none", nodata_borders=False))
