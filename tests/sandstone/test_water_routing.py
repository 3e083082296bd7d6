"""3D water routing (002 §6.2): receivers, depression routing and discharge, checked against
water conservation, exact upslope counts, the project's 2D routing and brute-force chains."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.hydro import accumulate, outlet_mask, route
from unerode_cli.sandstone.basins import route_depressions
from unerode_cli.sandstone.discharge import discharge
from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.water_receivers import EXIT, PIT, SEALED, SOLID, water_receivers

#: A grid of 1 m cells; every top of the heightfield tests lies in level LEVEL (3 to 4 m).
GRID = Grid3D((0.0, 0.0, 0.0), 1.0, (16, 14, 8))
LEVEL = 3


def _columns(tops: np.ndarray, grid: Grid3D = GRID) -> np.ndarray:
    """Particles of rock columns over the ground, one per cell below each column's top (m,
    ``(nx, ny)``) at the cell's centre and one at the top itself (the proxy elevation)."""
    nx, ny = tops.shape
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(grid.shape[2]), indexing="ij")
    below = (k + 1) * grid.h <= tops[..., None]
    fill = np.column_stack([i[below], j[below], k[below]]) * grid.h + 0.5 * grid.h
    i2, j2 = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    crest = np.column_stack([(i2.ravel() + 0.5) * grid.h, (j2.ravel() + 0.5) * grid.h, tops.ravel()])
    return np.vstack([fill, crest])


def _routing(positions: np.ndarray, grid: Grid3D = GRID, seed: int = 0, frame: int = 0):
    return route_depressions(water_receivers(positions, grid, seed, frame))


def _cavernous_rock(seed: int) -> tuple[np.ndarray, Grid3D]:
    """A rough block with overhangs and holes (random particles in random cells) around a
    cavity sealed in the rock, one particle per filled cell at a random height in it."""
    grid = Grid3D((0.0, 0.0, 0.0), 1.0, (18, 16, 12))
    rng = np.random.default_rng(seed)
    i, j, k = np.meshgrid(*(np.arange(n) for n in grid.shape), indexing="ij")
    relief = 7.0 + 2.0 * np.sin(i / 3.0) * np.cos(j / 4.0) + rng.random(i.shape[:2])[..., None] * 2.0
    filled = (k < relief) & (rng.random(i.shape) > 0.12)  # random holes, overhangs and caves
    filled[3:15, 3:13, 0:4] = True
    filled[6:10, 6:10, 1] = False  # the sealed cavity: rock all around it, two cells thick above
    cells = np.argwhere(filled)
    positions = (cells + rng.random(cells.shape)) * grid.h
    return positions, grid


def test_water_is_conserved_and_a_sealed_cavity_is_removed(one_thread):
    positions, grid = _cavernous_rock(0)
    sources = [(7.5, 7.5, 1.5, 40.0),   # inside the sealed cavity
               (9.2, 8.1, 11.5, 25.0),  # in the air over the rock
               (2.5, 2.5, 0.5, 3.0)]    # in a cell of the rock or its holes
    routing = _routing(positions, grid, seed=3, frame=2)
    water = discharge(routing, 0.7, sources)
    assert routing.pits > 10 and routing.sealed >= 1
    columns = len(np.unique(grid.cells_of(positions)[:, :2], axis=0))
    assert water.inflow == pytest.approx(0.7 * columns + 68.0, rel=1e-12)
    assert water.lost >= 40.0  # the cavity's source
    assert water.outflow + water.lost == pytest.approx(water.inflow, rel=1e-12)
    cavity = np.ravel_multi_index((7, 7, 1), grid.shape)
    assert routing.receiver[cavity] == SEALED and water.q.ravel()[cavity] == 0.0


def test_every_receiver_chain_ends_out_of_the_domain(one_thread):
    positions, grid = _cavernous_rock(1)
    routing = _routing(positions, grid, seed=5, frame=1)
    receiver = routing.receiver
    assert not np.any(receiver == PIT)
    routed = np.flatnonzero(receiver >= EXIT)
    carries = np.zeros(receiver.size, dtype=bool)
    carries[routing.order] = True
    filled = routing.top.ravel() > -np.inf
    assert np.all(carries[routed[filled[routed]]]) and not np.any(carries & (receiver < EXIT))
    downstream = receiver[routing.order]
    assert np.all(carries[downstream[downstream >= 0]])  # the order holds every chain it starts
    walker = routed.copy()
    for _ in range(routed.size):  # brute force: walk every chain a step at a time
        moving = receiver[walker] >= 0
        if not moving.any():
            break
        walker[moving] = receiver[walker[moving]]
    assert np.all(receiver[walker] == EXIT)
    position = np.empty(receiver.size, dtype=np.int64)
    position[routing.order] = np.arange(routing.order.size)
    donors = routing.order[receiver[routing.order] >= 0]
    assert np.all(position[donors] < position[receiver[donors]])  # each cell before its receiver


def test_a_tilted_plane_gathers_the_rain_of_its_upslope_columns(one_thread):
    """Tops falling 0.01 m per column westward (tied along y): water runs west along each
    row, so Q = p h² × the columns upslope of a cell, itself included, up to the upslope edge
    column, which drains out of the grid eastward; the two edge rows drain out sideways."""
    nx, ny = GRID.shape[:2]
    tops = np.broadcast_to(LEVEL + 0.2 + 0.01 * np.arange(nx)[:, None], (nx, ny)).copy()
    p = 0.25  # a power of 2: the sums are exact
    routing = _routing(_columns(tops), seed=7)
    water = discharge(routing, p)
    assert routing.pits == 0
    q = water.q[:, :, LEVEL]
    upslope = (nx - 1) - np.arange(1, nx - 1)
    assert np.array_equal(q[1:-1, 1:-1], np.broadcast_to(p * upslope[:, None], (nx - 2, ny - 2)))
    assert q[0, 5] == p * (nx - 1) and q[nx - 1, 5] == p and q[4, 0] == p
    assert water.outflow == pytest.approx(p * nx * ny, rel=1e-12)


def test_an_extruded_dem_routes_as_the_2d_routing():
    """A valley along x (rising 0.01 m per column eastward) between flanks rising 0.05 m per
    row away from it, tied along x, so every cell has one lower side neighbour and the 3D
    receivers are certain: Q on the surface equals the project's 2D D8 accumulation (whose
    steepest neighbour is that side neighbour) with every edge an outlet. Distinct heights
    everywhere would give cells several lower neighbours, among which 002 draws at random."""
    nx, ny = GRID.shape[:2]
    valley = 6
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    distance = np.abs(j - valley)
    tops = np.where(distance == 0, LEVEL + 0.05 + 0.01 * i, LEVEL + 0.3 + 0.05 * distance)
    p = 0.3
    q3d = discharge(_routing(_columns(tops), seed=2), p).q[:, :, LEVEL]
    elevation = tops.T[::-1].copy()  # row 0 at the north: y index ny - 1
    grid = Grid.full(elevation.shape, GRID.h)
    routing2d = route(elevation, grid, outlet_mask(grid, "all"), method="d8")
    q2d = accumulate(routing2d, p)[::-1].T
    np.testing.assert_allclose(q3d, q2d, rtol=1e-12)
    assert q3d.max() > 20 * p  # the valley gathered the flanks' rain


def test_a_closed_bowl_drains_through_its_spill_point(one_thread):
    """A bowl (centre (7, 7)) inside a rim at 3.9 m notched at 3.75 m at (7, 11), in a cone
    falling to the grid's edges: the bowl's pit is rerouted to its pass at the notch, all its
    rain leaves through the notch, and none crosses the rest of the rim."""
    nx, ny = GRID.shape[:2]
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    r2 = (i - 7) ** 2 + (j - 7) ** 2
    r = np.sqrt(r2)
    tops = np.where(r < 4, LEVEL + 0.5 + 0.01 * r2,
                    np.where(r < 5, LEVEL + 0.9, LEVEL + 0.7 - 0.04 * (r - 5)))
    tops[7, 11] = LEVEL + 0.75
    p = 1.0
    routing = _routing(_columns(tops), seed=11)
    water = discharge(routing, p)
    pit = np.ravel_multi_index((7, 7, LEVEL), GRID.shape)
    bowl = routing.basin.reshape(GRID.shape)[:, :, LEVEL] == routing.basin[pit]
    assert routing.pits == 1 and routing.basin[pit] == 1
    notch = {np.ravel_multi_index(cell, GRID.shape) for cell in ((7, 11, LEVEL), (7, 12, LEVEL))}
    assert routing.receiver[pit] in notch
    rain = p * np.count_nonzero(bowl)  # one surface cell per column of the bowl's basin
    q = water.q[:, :, LEVEL]
    assert q[7, 7] == pytest.approx(rain, rel=1e-12)
    assert q[7, 12] >= rain
    rim = (r >= 4) & (r < 5)
    rim[7, 11] = False
    assert q[rim].max() < rain
    assert water.outflow == pytest.approx(p * nx * ny, rel=1e-12) and water.lost == 0.0


def test_routing_and_discharge_are_identical_on_one_and_two_threads(threads):
    positions, grid = _cavernous_rock(2)
    runs = []
    for n in (1, 2):
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
        routing = _routing(positions, grid, seed=9, frame=4)
        runs.append((routing.receiver, routing.order, discharge(routing, 0.5, [(9.0, 8.0, 11.0, 7.0)]).q))
    for a, b in zip(runs[0], runs[1], strict=True):
        assert np.array_equal(a, b)
    other = _routing(positions, grid, seed=10, frame=4)
    assert not np.array_equal(other.receiver, runs[0][0])


def test_solid_rock_is_masked_and_ceilings_drain_down(one_thread):
    """A slab over an empty cell: its ceiling cell drains into the hole below, the slab's
    inner cells are solid, and the hole's water falls to the ground, out of the domain."""
    grid = Grid3D((0.0, 0.0, 0.0), 1.0, (5, 5, 4))
    filled = np.zeros(grid.shape, dtype=bool)
    filled[:, :, 0:4] = True
    filled[2, 2, 0] = False  # a hole under the slab, at the ground
    positions = (np.argwhere(filled) + 0.5) * grid.h
    receiver = water_receivers(positions, grid, 0, 0).receiver.reshape(grid.shape)
    assert receiver[2, 2, 1] == np.ravel_multi_index((2, 2, 0), grid.shape)
    assert receiver[2, 2, 0] == EXIT
    assert receiver[2, 2, 2] == SOLID and receiver[1, 2, 1] == SOLID
