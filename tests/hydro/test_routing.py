"""Flow routing: conservation, receivers, depression handling, MFD weights, D8 ties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unerode_cli.grid import Grid
from unerode_cli.hydro import accumulate, drainage_area, outlet_mask, route

METHODS = ("mfd", "d8")
NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def tilted_plane(shape: tuple[int, int], dx: float) -> np.ndarray:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    return 0.02 * dx * (shape[0] - rows) + 0.005 * dx * cols


def cone(shape: tuple[int, int], dx: float) -> np.ndarray:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    return 1000.0 - 0.1 * dx * np.hypot(rows - shape[0] / 2, cols - shape[1] / 2)


def check_receivers_are_lower(routing) -> None:
    """Every valid non-outlet cell sends all its flow to strictly lower valid neighbours."""
    fractions = routing.fractions()
    free = routing.grid.valid & ~routing.outlets
    np.testing.assert_allclose(fractions.sum(axis=2)[free], 1.0, rtol=1e-12)
    assert not fractions[~free].any()
    ny, nx = routing.grid.shape
    padded = np.pad(routing.filled, 1, constant_values=np.inf)
    for k, (dr, dc) in enumerate(NEIGHBOURS):
        neighbour = padded[1 + dr : 1 + dr + ny, 1 + dc : 1 + dc + nx]
        sends = fractions[:, :, k] > 0
        assert (neighbour[sends] < routing.filled[sends]).all()


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("surface", [tilted_plane, cone])
def test_outlets_collect_all_precipitation(method: str, surface) -> None:
    grid = Grid.full((40, 30), 25.0, 40.0)
    outlets = outlet_mask(grid, "all")
    routing = route(surface(grid.shape, 25.0), grid, outlets, method)
    precipitation = np.random.default_rng(1).uniform(0.2, 2.0, grid.shape)
    discharge = accumulate(routing, precipitation)
    total = precipitation.sum() * grid.cell_area
    assert discharge[outlets].sum() == pytest.approx(total, rel=1e-9)
    area = drainage_area(routing)
    assert area[outlets].sum() == pytest.approx(grid.valid.sum() * 25.0 * 40.0, rel=1e-9)
    assert area.min() == pytest.approx(grid.cell_area, rel=1e-12)


def test_hand_computed_d8_drainage_area() -> None:
    # h = 4 (4 - row) + 5 |col - 2|, one outlet at (4, 2), dx = dy = 10 m.
    # Steepest descent, by hand: column 2 flows south (drop 4, slope 0.4); columns 0, 1 flow
    # south-east and columns 3, 4 south-west (drop 9 over 10 √2 m: slope 0.64 > 0.5 east/west);
    # on the last row there is no row below, so (4, 0) -> (4, 1) -> (4, 2) <- (4, 3) <- (4, 4).
    # Counting upstream cells: (r, 0) = 1, (r, 1) = 1 + (r-1, 0), (r, 2) = 1 + (r-1, 1..3),
    # and (4, 1) = 1 + (4, 0) + (3, 0) = 3; the outlet collects all 25 cells.
    rows, cols = np.mgrid[0:5, 0:5]
    elevation = 4.0 * (4 - rows) + 5.0 * np.abs(cols - 2)
    grid = Grid.full((5, 5), 10.0)
    dirichlet = np.zeros((5, 5), dtype=bool)
    dirichlet[4, 2] = True
    routing = route(elevation, grid, outlet_mask(grid, "none", dirichlet=dirichlet), "d8")
    expected_cells = np.array(
        [
            [1, 1, 1, 1, 1],
            [1, 2, 4, 2, 1],
            [1, 2, 9, 2, 1],
            [1, 2, 14, 2, 1],
            [1, 3, 25, 3, 1],
        ]
    )
    np.testing.assert_allclose(drainage_area(routing), 100.0 * expected_cells, rtol=1e-12)
    receivers = routing.receivers()
    assert receivers[0, 0] == 1 * 5 + 1  # south-east
    assert receivers[2, 2] == 3 * 5 + 2  # south
    assert receivers[4, 4] == 4 * 5 + 3  # west
    assert receivers[4, 2] == -1  # the outlet is a sink


@pytest.mark.parametrize("method", METHODS)
def test_every_cell_drains_after_priority_flood(method: str) -> None:
    rng = np.random.default_rng(3)
    grid = Grid.full((64, 48), 30.0)
    elevation = rng.random(grid.shape) * 50.0  # pits everywhere
    elevation[20:30, 10:20] = 7.0  # and a flat plateau
    original = elevation.copy()
    outlets = outlet_mask(grid, "S,E")
    routing = route(elevation, grid, outlets, method)
    np.testing.assert_array_equal(elevation, original)  # the real surface is untouched
    free = ~outlets
    assert (routing.receivers()[free] >= 0).all()
    assert (routing.receivers()[outlets] == -1).all()
    assert (routing.filled >= elevation).all()
    assert (routing.filled[outlets] == elevation[outlets]).all()
    check_receivers_are_lower(routing)


def test_priority_flood_fills_a_pit_to_its_spill_level() -> None:
    # A bowl at 2 m inside a 10 m rim, with a 4 m notch in the rim towards the western
    # outlet column (0 m): the bowl fills to just above 4 m, nothing else changes.
    elevation = np.full((7, 7), 10.0)
    elevation[1:6, 2:6] = 2.0
    elevation[:, 0] = 0.0
    elevation[3, 1] = 4.0
    grid = Grid.full((7, 7), 10.0)
    routing = route(elevation, grid, outlet_mask(grid, "W", nodata_borders=False))
    basin = routing.filled[1:6, 2:6]
    assert (basin > 4.0).all() and (basin < 4.0 + 1e-6).all()
    outside = elevation != 2.0
    np.testing.assert_array_equal(routing.filled[outside], elevation[outside])
    # all the water of the 20 bowl cells leaves through the notch
    assert drainage_area(routing)[3, 1] >= (1 + 20) * 100.0 * (1 - 1e-12)


def test_order_puts_donors_before_receivers() -> None:
    rng = np.random.default_rng(5)
    grid = Grid.full((30, 40), 10.0)
    routing = route(rng.random(grid.shape), grid, outlet_mask(grid, "all"))
    assert np.array_equal(np.sort(routing.order), np.arange(30 * 40))
    assert (np.diff(routing.filled.ravel()[routing.order]) <= 0).all()  # a descending sort
    position = np.empty(30 * 40, dtype=int)
    position[routing.order] = np.arange(routing.order.size)
    fractions = routing.fractions().reshape(-1, 8)
    offsets = np.array([-41, -40, -39, -1, 1, 39, 40, 41])
    donors, directions = np.nonzero(fractions)
    receivers = donors + offsets[directions]
    assert (position[donors] < position[receivers]).all()


@pytest.mark.parametrize("method", METHODS)
def test_nodata_carries_no_flow(method: str) -> None:
    rows, cols = np.mgrid[0:32, 0:32]
    elevation = 100.0 - 2.0 * rows + 0.3 * np.abs(cols - 16)
    valid = np.ones((32, 32), dtype=bool)
    valid[12:18, 10:22] = False  # a lake of nodata in the way of the flow
    elevation[~valid] = -9999.0  # nodata values must not attract flow
    grid = Grid(20.0, 20.0, valid)
    outlets = outlet_mask(grid, "S")  # the lake's shore is an outlet too
    routing = route(elevation, grid, outlets, method)
    area = drainage_area(routing)
    assert (area[~valid] == 0.0).all()
    np.testing.assert_allclose(area[outlets].sum(), valid.sum() * 400.0, rtol=1e-9)
    receivers = routing.receivers()
    sends = receivers >= 0
    assert valid.ravel()[receivers[sends]].all()
    fractions = routing.fractions()
    ny, nx = grid.shape
    padded_valid = np.pad(valid, 1, constant_values=False)
    for k, (dr, dc) in enumerate(NEIGHBOURS):
        neighbour_valid = padded_valid[1 + dr : 1 + dr + ny, 1 + dc : 1 + dc + nx]
        assert not fractions[:, :, k][~neighbour_valid].any()


def test_mfd_weights_follow_slopes_with_unequal_cell_sizes() -> None:
    # Centre 1 m above its 8 neighbours (all outlets); dx = 10 m, dy = 20 m.
    # 000 Eq. 6: fraction ∝ 1 / distance: 1/20 north-south, 1/10 east-west, 1/√500 diagonal.
    elevation = np.zeros((3, 3))
    elevation[1, 1] = 1.0

    def centre_fractions(grid: Grid) -> np.ndarray:
        return route(elevation, grid, outlet_mask(grid, "all")).fractions()[1, 1]

    fractions = centre_fractions(Grid.full((3, 3), 10.0, 20.0))
    d = 1.0 / np.sqrt(500.0)
    expected = np.array([d, 1 / 20, d, 1 / 10, 1 / 10, d, 1 / 20, d])
    np.testing.assert_allclose(fractions, expected / expected.sum(), rtol=1e-12)
    square = centre_fractions(Grid.full((3, 3), 10.0))
    assert square[3] == pytest.approx(square[1], rel=1e-12)  # east = north when dx = dy
    assert fractions[3] == pytest.approx(2.0 * fractions[1], rel=1e-12)


@pytest.mark.parametrize(
    ("lowered", "expected"),
    [
        ([(0, 0), (0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1), (2, 2)], (0, 1)),  # N over S
        ([(1, 2), (2, 1)], (1, 2)),  # east before south in row-major order
        ([(0, 0), (2, 2)], (0, 0)),  # north-west before south-east
        ([(2, 0), (2, 2)], (2, 0)),  # south-west before south-east
    ],
)
def test_d8_ties_go_to_the_first_neighbour_in_row_major_order(lowered, expected) -> None:
    elevation = np.full((3, 3), 5.0)
    elevation[1, 1] = 3.0
    for cell in lowered:
        elevation[cell] = 0.0
    grid = Grid.full((3, 3), 10.0)
    routing = route(elevation, grid, outlet_mask(grid, "all"), "d8")
    assert routing.receivers()[1, 1] == expected[0] * 3 + expected[1]
    assert routing.fractions()[1, 1].sum() == 1.0


@settings(max_examples=40, deadline=None)
@given(
    shape=st.tuples(st.integers(2, 14), st.integers(2, 14)),
    seed=st.integers(0, 2**32 - 1),
    method=st.sampled_from(METHODS),
    holes=st.floats(0.0, 0.4),
    levels=st.sampled_from([0, 3, 1000]),
)
def test_random_surfaces_conserve_and_drain(shape, seed, method, holes, levels) -> None:
    rng = np.random.default_rng(seed)
    elevation = rng.random(shape) * 10.0
    if levels:
        elevation = np.round(elevation * levels / 10.0)  # integer DEMs make flats and ties
    valid = rng.random(shape) >= holes
    valid.flat[0] = True
    grid = Grid(7.0, 3.0, valid)
    routing = route(elevation, grid, outlet_mask(grid, "N"), method)
    check_receivers_are_lower(routing)
    assert (np.diff(routing.filled.ravel()[routing.order]) <= 0).all()
    area = drainage_area(routing)
    assert area[routing.outlets].sum() == pytest.approx(valid.sum() * 21.0, rel=1e-9)
    assert (area[~valid] == 0.0).all()
