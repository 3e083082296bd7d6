"""Deposition (002 §7): particle counts, a point-source pile at the angle of repose, walls and
pointer jumping, and determinism across thread counts."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from unerode_cli.sandstone import deposition
from unerode_cli.sandstone.deposition import DepositionParams, deposit, offset_grid
from unerode_cli.sandstone.grid3d import Grid3D

#: The deposition grid of a lattice of 1 m spacing: MPM cells, 2 m, 8 particles when full.
GRID = Grid3D((0.0, 0.0, 0.0), 2.0, (20, 20, 10))



def _rough_rock(seed: int) -> np.ndarray:
    """Particles (1 per m³) of a rough ridge along y whose west flank reaches the grid's side."""
    rng = np.random.default_rng(seed)
    x, y, z = np.meshgrid(np.arange(40) + 0.5, np.arange(40) + 0.5, np.arange(20) + 0.5, indexing="ij")
    top = 14.0 - 0.6 * np.abs(x - 12.0) + 3.0 * rng.random(x.shape[:2])[..., None]
    points = np.column_stack([x[z < top], y[z < top], z[z < top]])
    return points + (rng.random(points.shape) - 0.5) * 0.5


def _pile(repose: float, count: int) -> np.ndarray:
    """Drop ``count`` particles one per frame from 19 m above the centre of the empty grid."""
    params = DepositionParams(repose_angle=repose)
    source = np.array([[20.0, 20.0, 19.0]])
    pile = np.zeros((0, 3))
    for frame in range(count):
        grid = offset_grid(GRID, 3, frame)
        placed, exported = deposit(source, grid.occupancy(pile), grid, params, 3, frame)
        assert len(placed) == 1 and exported == 0
        pile = np.vstack([pile, placed])
    return pile


def _flank_angle(pile: np.ndarray) -> float:
    """Slope (degrees) of the line fitted to the pile's top (1 m columns) against the distance
    from its axis, between 20 % and 80 % of its height."""
    columns = np.floor(pile[:, :2]).astype(int)
    top = np.zeros((40, 40))
    np.maximum.at(top, (columns[:, 0], columns[:, 1]), pile[:, 2] + 0.5)
    x, y = np.meshgrid(np.arange(40) + 0.5, np.arange(40) + 0.5, indexing="ij")
    radius = np.hypot(x - 20.0, y - 20.0)
    flank = (top > 0.2 * top.max()) & (top < 0.8 * top.max())
    slope, _ = np.polyfit(radius[flank], top[flank], 1)
    return math.degrees(math.atan(-slope))


def test_every_eroded_particle_is_deposited_or_exported():
    rock = _rough_rock(0)
    rng = np.random.default_rng(1)
    params = DepositionParams(repose_angle=30.0)
    exported_total = 0
    for frame in range(6):
        # eroded: a few from the ridge's surface, some above the grid, some beyond its sides
        eroded = np.vstack([rock[rng.choice(len(rock), 300, replace=False)],
                            rng.random((20, 3)) * [40.0, 40.0, 10.0] + [0.0, 0.0, 25.0],
                            rng.random((10, 3)) * [5.0, 40.0, 10.0] + [41.0, 0.0, 0.0]])
        grid = offset_grid(GRID, 9, frame)
        placed, exported = deposit(eroded, grid.occupancy(rock), grid, params, 9, frame)
        assert len(placed) + exported == len(eroded)
        assert exported >= 10
        assert np.all(placed[:, 2] >= 0.0)
        exported_total += exported
        rock = np.vstack([rock, placed])
    assert exported_total > 60  # the ridge's west flank sheds over the side too


@pytest.mark.parametrize("repose", [25.0, 40.0])
def test_a_point_source_pile_stands_at_the_angle_of_repose(repose, threads):
    numba.set_num_threads(1)  # 1500 small calls: thread start-up would dominate
    assert _flank_angle(_pile(repose, 1500)) == pytest.approx(repose, abs=5.0)


def test_a_particle_eroded_from_a_wall_comes_to_rest_at_its_foot():
    occupancy = np.zeros(GRID.shape, dtype=np.int32)
    occupancy[10, 10, :8] = 8  # a tower 16 m high on flat ground
    eroded = np.array([[20.5, 21.0, 9.0]])  # inside its east face, 9 m up
    placed, exported = deposit(eroded, occupancy, GRID, DepositionParams(), 0, 0)
    assert exported == 0
    cell = GRID.cells_of(placed)[0]
    assert abs(cell[0] - 10) + abs(cell[1] - 10) == 1  # beside the tower
    assert placed[0, 2] == pytest.approx(0.5 * GRID.h / 8)  # on the ground: the first of 8 per cell


def test_pointer_jumping_finds_the_end_of_every_chain():
    rng = np.random.default_rng(2)
    n = 5000
    receiver = np.arange(n)
    order = rng.permutation(n)  # each node gives to one later in this order, or to itself
    for position in range(n - 1):
        if rng.random() < 0.97:
            receiver[order[position]] = order[rng.integers(position + 1, min(n, position + 40))]
    end = deposition._jump(receiver)
    walked = receiver.copy()
    for _ in range(n):
        walked = receiver[walked]
    assert np.array_equal(end, walked)
    assert np.all(receiver[end] == end)


def test_deposition_is_identical_on_one_and_two_threads(threads):
    rock = _rough_rock(4)
    eroded = rock[np.random.default_rng(5).choice(len(rock), 500, replace=False)]
    runs = []
    for n in (1, 2):
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
        grid = offset_grid(GRID, 6, 2)
        runs.append(deposit(eroded, grid.occupancy(rock), grid, DepositionParams(), 6, 2))
    assert np.array_equal(runs[0][0], runs[1][0]) and runs[0][1] == runs[1][1]
    grid = offset_grid(GRID, 7, 2)
    other = deposit(eroded, grid.occupancy(rock), grid, DepositionParams(), 7, 2)
    assert not np.array_equal(runs[0][0], other[0])


def test_the_offset_grid_covers_the_grid_on_the_same_ground():
    moved = offset_grid(GRID, 1, 5)
    assert moved.origin[2] == GRID.origin[2] and moved.h == GRID.h
    assert all(-GRID.h < moved.origin[a] - GRID.origin[a] <= 0.0 for a in (0, 1))
    assert all(moved.origin[a] + moved.shape[a] * moved.h >= GRID.origin[a] + GRID.shape[a] * GRID.h
               for a in (0, 1))
    assert offset_grid(GRID, 1, 6).origin != moved.origin
