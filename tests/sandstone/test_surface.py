"""Surface particles and normals (002 §5.1) against a block's exposed cells and a sphere's
radii; normals recomputed near changes equal normals recomputed everywhere."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from unerode_cli.sandstone import surface
from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.sampling import Lattice, sample

RADIUS = 12.0  # sphere radius in lattice spacings (m, spacing 1 m)
CENTRE = np.array([16.0, 16.0, 16.0])


class Ball:
    def __init__(self, centre: np.ndarray, radius: float) -> None:
        self.centre, self.radius = centre, radius

    def contains(self, points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points - self.centre, axis=1) < self.radius



@pytest.fixture(scope="module")
def sphere() -> tuple[np.ndarray, Grid3D]:
    """A sphere of radius 12 spacings on the sampler's jittered lattice, and its surface grid."""
    lattice = Lattice((0.0, 0.0, 0.0), (32.0, 32.0, 32.0), 1.0)
    return sample(Ball(CENTRE, RADIUS), lattice, seed=3), lattice.surface_grid()


def test_a_block_on_the_ground_exposes_all_but_its_core_and_its_base():
    occupancy = np.zeros((6, 6, 6), dtype=np.int32)
    occupancy[1:5, 1:5, 0:4] = 2
    cells = surface.surface_cells(occupancy)
    # 4 × 4 × 4 cells; the 2 × 2 × 3 core (bottom row included: the ground covers it) is hidden
    assert cells.sum() == 64 - 12
    assert not cells[2:4, 2:4, 0:3].any() and cells[2:4, 2:4, 3].all()


def test_particles_are_on_the_surface_where_their_cell_is():
    grid = Grid3D((0.0, 0.0, 0.0), 1.0, (4, 4, 4))
    positions = np.array([[1.5, 1.5, 0.5], [0.5, 0.5, 0.5], [9.0, 1.5, 0.5], [1.5, 1.5, -2.0]])
    # a lone particle on the ground is exposed (sides, top); outside the grid: exposed unless
    # below the ground
    assert surface.surface_particles(positions, grid).tolist() == [True, True, True, False]


def test_normals_of_a_sphere_point_outward_within_3_degrees(sphere):
    positions, grid = sphere
    on_surface = surface.surface_particles(positions, grid)
    normals = surface.normals(positions, on_surface, grid)
    radial = positions[on_surface] - CENTRE
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    cosine = np.sum(normals[on_surface] * radial, axis=1)
    assert on_surface.sum() > 1000
    assert np.median(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))) < 3.0
    assert cosine.min() > 0.0
    assert np.allclose(np.linalg.norm(normals[on_surface], axis=1), 1.0)
    assert not normals[~on_surface].any()


def test_normals_recomputed_near_changes_equal_normals_recomputed_everywhere(sphere, threads):
    positions, grid = sphere
    on_surface = surface.surface_particles(positions, grid)
    before = surface.normals(positions, on_surface, grid)
    # erode a cap of the sphere: the particles within 4 m of its top
    eroded = np.linalg.norm(positions - (CENTRE + [0.0, 0.0, RADIUS]), axis=1) < 4.0
    kept = positions[~eroded]
    kept_surface = surface.surface_particles(kept, grid)
    recompute = surface.near_changes(kept, positions[eroded], grid)
    full = surface.normals(kept, kept_surface, grid)
    for n in (1, 2):
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
        partial = surface.normals(kept, kept_surface, grid, previous=before[~eroded], recompute=recompute)
        assert np.array_equal(partial, full)
    assert 0 < recompute.sum() < 0.5 * len(kept)
    # the flags matter: without them the old normals of the cap's rim stay
    stale = surface.normals(kept, kept_surface, grid, previous=before[~eroded],
                            recompute=np.zeros(len(kept), dtype=bool))
    assert np.abs(stale - full).max() > 0.1
