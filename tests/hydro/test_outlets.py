"""Outlet masks: edges, nodata borders, Dirichlet nodes, sea level."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.hydro import outlet_mask, parse_edges, require_outlets, route


def test_parse_edges() -> None:
    assert parse_edges("all") == {"N", "E", "S", "W"}
    assert parse_edges("NONE") == frozenset()
    assert parse_edges(" s, w ") == {"S", "W"}
    for bad in ("X", "N,,S", "", "north"):
        with pytest.raises(ValueError, match="comma list"):
            parse_edges(bad)


def test_edges_pick_the_right_rows_and_columns() -> None:
    grid = Grid.full((4, 5), 10.0)
    north_east = outlet_mask(grid, "N,E")
    expected = np.zeros((4, 5), dtype=bool)
    expected[0, :] = True  # row 0 is north
    expected[:, 4] = True  # last column is east
    np.testing.assert_array_equal(north_east, expected)
    assert outlet_mask(grid, "all").sum() == 2 * 5 + 2 * 4 - 4
    assert outlet_mask(grid, "S")[3].all() and outlet_mask(grid, "S").sum() == 5
    assert outlet_mask(grid, "W")[:, 0].all() and outlet_mask(grid, "W").sum() == 4


def test_nodata_borders_are_outlets_and_nodata_never() -> None:
    valid = np.ones((7, 7), dtype=bool)
    valid[3, 3] = False  # a one-cell hole: its 8 neighbours become outlets
    valid[0, 0] = False  # nodata on the edge: never an outlet itself
    grid = Grid(10.0, 10.0, valid)
    holes_only = outlet_mask(grid, "none")
    assert holes_only.sum() == 8 + 3  # 8 around the hole, 3 around the corner
    assert holes_only[2:5, 2:5].sum() == 8 and not holes_only[3, 3]
    assert not outlet_mask(grid, "all")[0, 0]
    assert not outlet_mask(grid, "none", nodata_borders=False).any()


def test_dirichlet_and_sea_level() -> None:
    grid = Grid.full((5, 6), 30.0)
    elevation = np.arange(30, dtype=float).reshape(5, 6)
    dirichlet = np.zeros((5, 6), dtype=bool)
    dirichlet[2, 3] = True
    mask = outlet_mask(grid, "none", dirichlet=dirichlet)
    assert mask.sum() == 1 and mask[2, 3]
    sea = outlet_mask(grid, "none", elevation=elevation, sea_level=7.0)
    np.testing.assert_array_equal(sea, elevation <= 7.0)
    assert sea.sum() == 8
    with pytest.raises(ValueError, match="elevation"):
        outlet_mask(grid, "none", sea_level=0.0)
    with pytest.raises(ValueError, match="shape"):
        outlet_mask(grid, "none", dirichlet=np.ones((2, 2), dtype=bool))


def test_no_outlet_is_one_clear_error() -> None:
    grid = Grid.full((6, 6), 10.0)
    outlets = outlet_mask(grid, "none")
    with pytest.raises(ValueError, match="no outlet"):
        require_outlets(outlets)
    with pytest.raises(ValueError, match="no outlet"):
        route(np.zeros((6, 6)), grid, outlets)


def test_island_without_outlet_is_refused() -> None:
    valid = np.ones((6, 9), dtype=bool)
    valid[:, 4] = False  # two islands, only the western one touches an outlet
    grid = Grid(10.0, 10.0, valid)
    outlets = outlet_mask(grid, "W", nodata_borders=False)
    with pytest.raises(ValueError, match="24 valid cells cannot drain"):
        route(np.random.default_rng(0).random((6, 9)), grid, outlets)
