"""Block fall (002 Fig. 3): rock cut off the ground falls and lands as debris."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.sandstone.grid3d import Grid3D
from unerode_cli.sandstone.mpm import MpmParams
from unerode_cli.sandstone.sampling import lattice_for, scene_particles
from unerode_cli.sandstone.scene import parse_scene
from unerode_cli.sandstone.simulation import Processes, Simulation, SimulationParams
from unerode_cli.sandstone.support import unsupported

pytestmark = pytest.mark.usefixtures("one_thread")


def test_a_piece_touching_the_ground_only_through_another_is_supported() -> None:
    grid = Grid3D((0.0, 0.0, 0.0), 1.0, (10, 10, 10))
    column = [(2.5, 2.5, z + 0.5) for z in range(6)]            # on the ground
    bridge = [(3.5 + x, 2.5, 5.5) for x in range(4)]            # hangs from the column's top
    floating = [(8.5, 8.5, 4.5), (8.5, 8.5, 5.5), (7.5, 7.5, 6.5)]  # touches nothing
    corner = [(7.5, 2.5, 0.5), (8.5, 3.5, 1.5)]                  # diagonal neighbours, on the ground
    falls = unsupported(np.array(column + bridge + floating + corner), grid)
    assert falls.tolist() == [False] * 10 + [True] * 3 + [False] * 2


def test_a_floating_block_reaches_the_ground_as_debris() -> None:
    """A 10 × 10 × 5 m block 6 m above a 2-m ground slab, nothing eroding: after one frame
    every particle of it is debris (a deposit) resting on the slab or on other debris, piled no
    higher than a cone of its volume at the angle of repose (33°: 6.1 m for 500 m³, plus a cell
    of the deposition grid), its centre of mass below 5 m (the block's was at 10.5 m); the slab
    is untouched and no particle is lost."""
    scene = parse_scene({"domain": {"size": [20.0, 20.0, 16.0]}, "shape": {"union": [
        {"box": {"min": [0, 0, 0], "max": [20, 20, 2]}},
        {"box": {"min": [5, 5, 8], "max": [15, 15, 13]}}]}})
    lattice, _ = lattice_for(scene.shape, scene.low, np.array(scene.domain.size), 12_000)
    particles = scene_particles(scene, lattice, 1)
    block = particles.positions[:, 2] > 2.0
    params = SimulationParams(processes=Processes(abrasion=False, deflation=False, fluvial=False),
                              mpm=MpmParams(substeps=5, settle_substeps=50))
    simulation = Simulation(particles, scene.layer_stack(), scene.rock_parameters(), lattice, params, seed=1)
    before = len(simulation.particles)
    stats = simulation.step()
    after = simulation.particles
    assert stats.eroded == 0 and stats.fallen == np.count_nonzero(block) == stats.fallen_landed
    assert len(after) == before
    debris = after.deposit
    assert np.count_nonzero(debris) == np.count_nonzero(block)
    volume = np.count_nonzero(block) * lattice.spacing**3
    cone = (3.0 * volume * np.tan(np.radians(33.0)) ** 2 / np.pi) ** (1.0 / 3.0)
    assert after.positions[debris, 2].min() < 2.0 + lattice.spacing
    assert after.positions[debris, 2].max() < 2.0 + cone + 2.0 * lattice.spacing
    assert after.positions[debris, 2].mean() < 5.0
    assert after.positions[~debris, 2].max() < 2.0
    assert not unsupported(after.positions, simulation.surface_grid).any()


def test_unsupported_particles_are_those_of_scipys_components_without_a_ground_cell() -> None:
    """Random rocks (a third of the cells filled, so pieces hang by corners, overhang and wind
    down and up again): the particles that fall are those whose 26-connected component
    (``scipy.ndimage.label``) holds no cell of the lowest layer, and those outside the grid."""
    from scipy import ndimage

    rng = np.random.default_rng(5)
    grid = Grid3D((0.0, 0.0, 0.0), 1.0, (9, 8, 7))
    for _ in range(20):
        positions = rng.random((200, 3)) * (np.array(grid.shape) + 1.0) - 0.5
        cells = grid.cells_of(positions)
        inside = grid.inside(cells)
        occupied = np.zeros(grid.shape, dtype=bool)
        occupied[tuple(cells[inside].T)] = True
        labels, _ = ndimage.label(occupied, structure=np.ones((3, 3, 3)))
        grounded = np.setdiff1d(np.unique(labels[:, :, 0]), [0])
        expected = ~inside
        expected[inside] = ~np.isin(labels[tuple(cells[inside].T)], grounded)
        assert np.array_equal(unsupported(positions, grid), expected)
