"""Particle densities: the volume they carry (a conservation law), the half-density boundary of a
flat face at any cell, the ground plane, the dominant material, and the memory a field takes
(against tracemalloc's count)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from tests.volume.conftest import jittered_lattice

from unerode_cli.volume.density import NO_MATERIAL, density_bytes, particle_density

SPACING = 0.5


def test_the_density_integrates_to_the_particles_volume() -> None:
    points = jittered_lattice((10, 12, 8), SPACING, low=(3.0, -2.0, 7.0))
    density = particle_density(points, np.zeros(len(points), dtype=int), SPACING**3, 0.4)
    assert density.values.sum() * 0.4**3 == pytest.approx(len(points) * SPACING**3, rel=1e-5)
    for axis in range(3):  # the grid's faces are empty: the surface is closed
        assert density.values.take([0, -1], axis=axis).max() == 0.0


def test_a_flat_face_lies_where_the_density_is_one_half() -> None:
    points = jittered_lattice((40, 40, 40), SPACING)  # a 20 m cube from the origin
    density = particle_density(points, np.zeros(len(points), dtype=int), SPACING**3, SPACING)
    x = density.origin[0] + SPACING * np.arange(density.values.shape[0])
    j, k = (int(round((10.0 - density.origin[a]) / SPACING)) for a in (1, 2))
    profile = density.values[:, j, k]
    assert profile.max() == pytest.approx(1.0, abs=0.05)
    assert np.interp(0.0, x, profile) == pytest.approx(0.5, abs=0.05)


def test_on_the_ground_the_rock_keeps_its_full_density_down_to_the_ground() -> None:
    points = jittered_lattice((20, 20, 10), SPACING, low=(0.0, 0.0, 100.0))
    density = particle_density(points, np.zeros(len(points), dtype=int), SPACING**3, SPACING, ground=100.0)
    assert density.origin[2] == pytest.approx(100.0 - SPACING) and density.ground == 100.0
    centre = tuple(int(round((5.0 - density.origin[a]) / SPACING)) for a in (0, 1))
    column = density.values[centre[0], centre[1], :]
    assert column[0] == 0.0  # below the ground
    assert column[1] == pytest.approx(1.0, abs=0.05)  # on the ground, under 5 m of rock


def test_each_node_takes_the_material_of_most_rock_around_it() -> None:
    points = jittered_lattice((30, 10, 10), SPACING)  # 15 m along x: materials 2 then 5 at x = 7.5
    materials = np.where(points[:, 0] < 7.5, 2, 5)
    density = particle_density(points, materials, SPACING**3, SPACING)
    x = density.origin[0] + SPACING * np.arange(density.values.shape[0])
    row = density.materials[:, density.values.shape[1] // 2, density.values.shape[2] // 2]
    assert np.all(row[(x > 0.0) & (x < 7.0)] == 2) and np.all(row[(x > 8.0) & (x < 15.0)] == 5)
    assert np.all(density.materials[density.values == 0.0] == NO_MATERIAL)


def test_negative_materials_and_no_particles_are_refused() -> None:
    with pytest.raises(ValueError, match="non-negative"):
        particle_density(np.zeros((2, 3)), np.array([0, -1]), 1.0, 1.0)
    with pytest.raises(ValueError, match="no particles"):
        particle_density(np.zeros((0, 3)), np.zeros(0, dtype=int), 1.0, 1.0)


@pytest.mark.parametrize("cell", [SPACING / 2, 2 * SPACING])
def test_at_any_cell_the_field_holds_the_particles_volume_and_a_flat_face_stays(cell: float) -> None:
    """The face (x = 0) is where the field, interpolated between nodes as marching cubes does,
    crosses ½, within a quarter spacing."""
    points = jittered_lattice((40, 40, 40), SPACING)  # a 20 m cube from the origin
    density = particle_density(points, np.zeros(len(points), dtype=int), SPACING**3, cell)
    assert density.h == cell
    assert density.values.sum() * cell**3 == pytest.approx(len(points) * SPACING**3, rel=1e-5)
    x = density.origin[0] + cell * np.arange(density.values.shape[0])
    j, k = (int(round((10.0 - density.origin[a]) / cell)) for a in (1, 2))
    rising = density.values[: len(x) // 2, j, k]  # increasing up to the inside
    assert np.interp(0.5, rising, x[: len(x) // 2]) == pytest.approx(0.0, abs=SPACING / 4)


@pytest.mark.parametrize(("cell", "ground", "particles", "layers"), [(SPACING / 4, None, (24, 20, 16), 4),
                                                                    (2 * SPACING, 0.0, (100, 100, 40), 1)])
def test_the_memory_estimate_bounds_what_is_allocated(cell: float, ground: float | None,
                                                      particles: tuple[int, int, int], layers: int) -> None:
    """Peak allocations (tracemalloc) of a grid-bound field (a fine cell, four materials) and of a
    particle-bound one (400 000 particles of one material, the most a particle takes, on the
    ground and a coarse cell)."""
    points = jittered_lattice(particles, SPACING, seed=5)
    materials = (points[:, 2] // 3.0).astype(int) % layers
    estimate = density_bytes(points.min(axis=0), points.max(axis=0), len(points), SPACING**3, cell,
                             ground=ground)
    tracemalloc.start()
    try:
        particle_density(points, materials, SPACING**3, cell, ground=ground)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert 0.6 * estimate < peak <= estimate


def test_a_field_above_the_memory_allowed_is_refused_before_it_is_made() -> None:
    points = jittered_lattice((10, 12, 8), SPACING)
    need = density_bytes(points.min(axis=0), points.max(axis=0), len(points), SPACING**3, SPACING / 2)
    materials = np.zeros(len(points), dtype=int)
    particle_density(points, materials, SPACING**3, SPACING / 2, max_bytes=need)
    with pytest.raises(ValueError, match=r"GiB allowed: choose a coarser cell"):
        particle_density(points, materials, SPACING**3, SPACING / 2, max_bytes=need - 1)
    with pytest.raises(ValueError, match=r"coarser cell"):  # about 10¹⁰ nodes: refused, not allocated
        particle_density(points, materials, SPACING**3, SPACING / 200)
