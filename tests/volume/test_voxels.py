"""Voxel grids of 3D terrains (003 §4.4): a block's density holds the matter under the DEM and
its f = 0 level is the DEM; impacts on density voxels conserve matter exactly (Eq. 13, with the
excess carried up or down the column); binary voxels count hits (Eq. 14) and flip whole voxels
by an exact integer bookkeeping; a voxelised sphere's normals; the closed mesh of a grid."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tests.volume.conftest import assert_watertight

from unerode_cli.particles import voxel_kernels as vk
from unerode_cli.volume import voxel_kernels as kv
from unerode_cli.volume.mesh import enclosed_volume, vertex_normals
from unerode_cli.volume.voxels import (
    BinaryVoxels,
    DensityVoxels,
    VoxelGeometry,
    binary_block,
    block_geometry,
    density_block,
    grid_to_xyz,
    ground_mesh,
    horizon_material,
    xyz_to_grid,
)

D = 2.0  # voxel size (m)
#: material rules of the kernels: no deposit material, no transformation, no erodibilities
NO_RULES = (-1, np.zeros(1, np.int16), np.zeros(0))


def _hills(shape: tuple[int, int], base: float = 20.0) -> np.ndarray:
    """Smooth heights (m): slopes below 0.5, so that no two neighbouring columns differ by a voxel."""
    r, c = np.mgrid[0 : shape[0], 0 : shape[1]] * D
    return base + 4.0 * np.sin(r / 9.0) * np.cos(c / 7.0) + 0.1 * c


def _block(shape=(16, 20), layers=24) -> tuple[VoxelGeometry, np.ndarray]:
    geometry = VoxelGeometry((0.0, shape[0] * D, 0.0), (D, D, D), (*shape, layers))
    return geometry, _hills(shape)


def test_a_block_holds_the_matter_under_the_dem_and_its_zero_level_is_the_dem() -> None:
    geometry, h = _block()
    f = density_block(h, geometry)
    voxels = DensityVoxels(geometry, f)
    # Σ (1 + f)/2 · V = ∫ (h − z0) dA: a ramp of width 2 dz sampled every dz sums to its integral
    assert voxels.matter() == pytest.approx(h.sum() * D * D, rel=1e-12)
    assert kv.top_surface(f, 0.0, D) == pytest.approx(h, abs=1e-9)
    rows, cols = np.mgrid[0:16, 0:20]
    x, y = cols.ravel() * D, rows.ravel() * D
    assert np.abs(vk.levels(f.astype(np.float32), x, y, h.ravel(), D, D, D, 0.0)).max() < 1e-5
    solid = binary_block(h, geometry)
    assert np.array_equal(solid.sum(axis=2), np.ceil(h / D - 0.5).astype(int))  # centres below h


def test_block_geometry_fits_columns_to_the_extent_and_layers_to_the_elevations() -> None:
    g = block_geometry(500.0, 2000.0, 300.0, 200.0, -12.0, 95.0, 7.0)
    assert g.shape == (29, 43, 16)  # 200/7 → 29 rows, 300/7 → 43 columns, ⌈107/7⌉ = 16 layers
    assert g.size[0] * g.shape[1] == pytest.approx(300.0) and g.size[1] * g.shape[0] == pytest.approx(200.0)
    assert g.origin == (500.0, 2000.0, -12.0) and g.origin[2] + g.shape[2] * g.size[2] >= 95.0
    with pytest.raises(ValueError, match="voxel size"):
        block_geometry(0.0, 0.0, 10.0, 10.0, 0.0, 1.0, 0.0)


def test_axes_round_trip_between_file_and_grid_layouts() -> None:
    a = np.arange(3 * 4 * 5).reshape(3, 4, 5)  # x east, y north, z up
    g = xyz_to_grid(a)
    assert g.shape == (4, 3, 5) and g[0, 0, 0] == a[0, 3, 0]  # row 0 is the north row, column 0 west
    assert np.array_equal(grid_to_xyz(g), a)


def _events(n: int, geometry: VoxelGeometry, h: np.ndarray, seed: int, scale: float):
    """n impacts on the surface of ``h`` with Q of both signs (m³) and radii of 1-3 voxels."""
    rng = np.random.default_rng(seed)
    rows, cols = geometry.shape[:2]
    r = rng.uniform(0, rows - 1, n)
    c = rng.uniform(0, cols - 1, n)
    z = h[np.rint(r).astype(int), np.rint(c).astype(int)]
    q = rng.normal(0.0, scale, n)
    radius = rng.uniform(1.0, 3.0, n) * D
    return c * D, r * D, z, q, radius


def test_density_impacts_change_the_matter_by_exactly_their_sum() -> None:
    geometry, h = _block()
    voxels = DensityVoxels(geometry, density_block(h, geometry))
    before = voxels.matter()
    x, y, z, q, radius = _events(2000, geometry, h, 1, 1.0 * D**3)  # about a voxel's worth each
    q[:5] = 8.0 * D**3  # deposits larger than the room within R: the excess is carried up
    empty = np.zeros((0, 0, 0), np.int16)
    left = kv.apply_density(voxels.density, empty, voxels.valid, D, D, D, 0.0, x, y, z, q, radius, NO_RULES)
    assert left == 0.0  # 24 layers leave room above and below
    assert voxels.density.min() >= -1.0 and voxels.density.max() <= 1.0
    assert voxels.matter() - before == pytest.approx(math.fsum(q), abs=1e-9 * before)


def test_what_leaves_through_the_top_or_bottom_is_reported() -> None:
    geometry = VoxelGeometry((0.0, 10.0, 0.0), (D, D, D), (5, 5, 3))
    voxels = DensityVoxels(geometry, np.zeros(geometry.shape))
    empty = np.zeros((0, 0, 0), np.int16)
    one = np.ones(1)
    before = voxels.matter()
    grid_volume = geometry.count * geometry.voxel_volume
    args = (voxels.density, empty, voxels.valid, D, D, D, 0.0)
    radius = one * 10 * D  # every voxel centre within R
    left = kv.apply_density(*args, 4 * one, 4 * one, 3 * one, one * grid_volume, radius, NO_RULES)
    assert voxels.density.min() == 1.0  # every voxel filled (half the grid's volume fitted) ...
    assert left == pytest.approx(grid_volume - 0.5 * grid_volume)  # ... the rest went through the top
    left = kv.apply_density(*args, 4 * one, 4 * one, 3 * one, -one * 2 * grid_volume, radius, NO_RULES)
    assert voxels.density.max() == -1.0 and left == pytest.approx(-grid_volume)  # through the bottom
    assert voxels.matter() - before == pytest.approx(-0.5 * grid_volume)


def test_a_small_impact_follows_eq_13_weights() -> None:
    geometry = VoxelGeometry((0.0, 20.0, 0.0), (D, D, D), (10, 10, 10))
    f = np.zeros(geometry.shape)
    c = np.array([9.3, 8.6, 9.1])  # x, y (grid coordinates, m), z
    q, radius = -0.5, 2.6 * D
    kv.apply_density(f, np.zeros((0, 0, 0), np.int16), np.ones((10, 10), bool), D, D, D, 0.0, c[:1], c[1:2],
                     c[2:], np.array([q]), np.array([radius]), NO_RULES)
    # brute force: w = 1 − d/R over the voxel centres within R, Δf = 2Q w / (V Σ w)
    rr, cc, kk = np.indices(geometry.shape)
    d = np.sqrt((cc * D - c[0]) ** 2 + (rr * D - c[1]) ** 2 + ((kk + 0.5) * D - c[2]) ** 2)
    w = np.where(d < radius, 1.0 - d / radius, 0.0)
    assert f == pytest.approx(2.0 * q * w / (D**3 * w.sum()), abs=1e-15)


def test_erosion_shares_an_impact_by_erodibility_deposits_do_not() -> None:
    geometry = VoxelGeometry((0.0, 20.0, 0.0), (D, D, D), (10, 10, 10))
    material = np.zeros(geometry.shape, np.int16)
    material[:, :, 5:] = 1  # soft above 10 m, hard below
    erodibility = np.array([0.5, 5.0])
    rules = (-1, np.array([0, 1], np.int16), erodibility)
    rr, cc, kk = np.indices(geometry.shape)
    c = np.array([9.3, 8.6, 10.4])
    d = np.sqrt((cc * D - c[0]) ** 2 + (rr * D - c[1]) ** 2 + ((kk + 0.5) * D - c[2]) ** 2)
    w = np.where(d < 2.6 * D, 1.0 - d / (2.6 * D), 0.0)
    for q, expected in ((-0.5, w * erodibility[material]), (0.5, w)):
        f = np.zeros(geometry.shape)
        kv.apply_density(f, material.copy(), np.ones((10, 10), bool), D, D, D, 0.0, c[:1], c[1:2], c[2:],
                         np.array([q]), np.array([2.6 * D]), rules)
        assert f == pytest.approx(2.0 * q * expected / (D**3 * expected.sum()), abs=1e-15)


def test_material_rules_recolour_deposits_and_eroded_ground() -> None:
    geometry, h = _block()
    initial = horizon_material(geometry, np.array([14.0, np.inf]), np.array([0, 1]))
    assert np.all(initial[:, :, 6] == 0) and np.all(initial[:, :, 7] == 1)  # centres 13 m and 15 m
    voxels = DensityVoxels(geometry, density_block(h, geometry), initial)
    on_erosion = np.array([0, 2, 2], np.int16)  # material 1 becomes 2 when eroded (003 §7)
    before = voxels.density.copy()
    x, y, z, q, radius = _events(400, geometry, h, 2, 2.0 * D**3)
    kv.apply_density(voxels.density, voxels.material, voxels.valid, D, D, D, 0.0, x, y, z, q, radius,
                     (0, on_erosion, np.zeros(0)))
    after = voxels.density
    new_ground = (before <= 0) & (after > 0)
    lowered = (after > 0) & (after < before)
    assert new_ground.sum() > 20 and lowered.sum() > 20
    assert np.all(voxels.material[new_ground] == 0)  # deposits become material 0
    assert not np.any(voxels.material[lowered] == 1)  # eroded ground of material 1 turned to 2
    assert np.all(initial[voxels.material == 2] == 1)  # and only material 1 did
    assert np.all(voxels.material[(after < -0.999) & (before < -0.999)] == initial[(after < -0.999)
                                                                                   & (before < -0.999)])


def test_binary_hits_balance_the_flips_exactly() -> None:
    geometry, h = _block()
    voxels = BinaryVoxels(geometry, binary_block(h, geometry))
    solid0 = voxels.solid.copy()
    alpha, threshold = 100.0, 100
    x, y, z, q, radius = _events(4000, geometry, h, 3, 1.5 * D**3)
    counters = kv.apply_binary(voxels.solid, voxels.hits, np.zeros((0, 0, 0), np.int16), voxels.valid,
                               D, D, D, 0.0, x, y, z, q, radius, alpha, threshold, NO_RULES)
    eroded, deposited, removed, added, transformed, unplaced = counters
    assert removed > 50 and added > 50 and transformed == 0 and unplaced == 0
    # flips both ways: the net is what changed
    net = np.count_nonzero(solid0 & ~voxels.solid) - np.count_nonzero(~solid0 & voxels.solid)
    assert removed - added == net
    # every hit is either still counted in a voxel or spent, C at a time, on a flip (003 Eq. 14)
    assert int(voxels.hits.sum()) == eroded - deposited - threshold * (removed - added)
    # ⌊α ΔV / V⌋ per voxel never overcounts, and with shares of ~10 hits loses a few per cent
    exact = alpha * np.abs(q).sum() / D**3
    assert 0.9 * exact < eroded + deposited <= exact


def test_deposits_in_one_column_flip_voxels_within_one_voxel_of_the_hits() -> None:
    geometry = VoxelGeometry((0.0, 10.0, 0.0), (D, D, D), (5, 5, 20))
    solid = np.zeros(geometry.shape, bool)
    solid[:, :, :4] = True
    voxels = BinaryVoxels(geometry, solid)
    n = 60  # about 13 voxels' worth, for the column's 16 voxels of air
    rng = np.random.default_rng(4)
    q = rng.uniform(0.05, 0.4, n) * D**3  # each deposit lands on the one air voxel within R
    x, y = np.full(n, 2 * D), np.full(n, 2 * D)
    z = np.full(n, 4.0 * D)
    alpha = 1000.0
    counters = kv.apply_binary(voxels.solid, voxels.hits, np.zeros((0, 0, 0), np.int16), voxels.valid,
                               D, D, D, 0.0, x, y, z, q, np.full(n, 0.4 * D), alpha, 1000, NO_RULES)
    added = counters[kv.ADDED]
    hit_volume = counters[kv.DEPOSITION_HITS] / alpha * D**3
    assert added * D**3 == pytest.approx(hit_volume, abs=D**3)
    assert hit_volume == pytest.approx(q.sum(), abs=n * D**3 / alpha)  # ⌊·⌋ loses < 1 hit per impact
    assert voxels.solid[2, 2].sum() == 4 + added  # the column grew from its top


def test_binary_erosion_transforms_a_material_before_removing_it() -> None:
    geometry = VoxelGeometry((0.0, 2.0, 0.0), (D, D, D), (1, 1, 4))
    voxels = BinaryVoxels(geometry, np.ones(geometry.shape, bool), material=np.full(geometry.shape, 1))
    one = np.ones(1)
    on_erosion = np.array([0, 0], np.int16)  # material 1 becomes 0 (clay → sand, 003 §7)
    counters = kv.apply_binary(voxels.solid, voxels.hits, voxels.material, voxels.valid, D, D, D, 0.0,
                               0 * one, 0 * one, 8.0 * one, -one * 2.5 * D**3, 0.4 * D * one, 10.0, 10,
                               (-1, on_erosion, np.zeros(0)))
    # 25 hits on the top voxel: 10 transform it to material 0, 10 more remove it, and the 5 left
    # go on to the voxel below
    assert counters[kv.TRANSFORMED] == 1 and counters[kv.REMOVED] == 1
    assert voxels.solid[0, 0].tolist() == [True, True, True, False]
    assert voxels.hits[0, 0].tolist() == [0, 0, 5, 0] and voxels.material[0, 0].tolist() == [1, 1, 1, 0]


def test_normals_of_a_voxelised_sphere_are_radial() -> None:
    """A sphere of radius ρ = 10 voxels stored as a density ramp two voxels wide, f = (ρ − r)/2h
    (h the voxel size; no voxel next to the surface is clipped to ±1). The trilinear gradient's
    x component is the difference quotient across the cell, which errs from ∂f/∂x at any point
    of the cell by at most h/2·|∂²f/∂x²| (plus an O(h²) term from the interpolation across y
    and z); the distance's second derivatives are at most 1/ρ, so each component of the unit
    normal errs by ≤ h/2ρ and the normal's angle by ≤ √3·h/2ρ = 0.087 rad. The level itself
    errs by ≤ (h²/8)·Σ|∂²r/∂x_i²| ≤ 3h²/8ρ (m) on the sphere."""
    n, rho = 32, 10.0 * D
    geometry = VoxelGeometry((0.0, n * D, 0.0), (D, D, D), (n, n, n))
    centre = np.array([15.5, 16.2, 15.8]) * D  # x, y (grid coordinates), z
    rows, cols, layers = np.indices(geometry.shape)
    p = np.stack([cols * D, rows * D, (layers + 0.5) * D], axis=-1)
    ramp = 2.0 * D
    f = np.clip((rho - np.linalg.norm(p - centre, axis=-1)) / ramp, -1.0, 1.0)
    rng = np.random.default_rng(5)
    u = rng.normal(size=(500, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    x, y, z = (np.ascontiguousarray(c) for c in (centre + rho * u).T)  # on the sphere
    level = f.astype(np.float32)
    normals = vk.normals(level, x, y, z, D, D, D, 0.0)
    angle = np.arccos(np.clip(np.einsum("ij,ij->i", normals, u), -1.0, 1.0))
    assert angle.max() < math.sqrt(3.0) * D / (2.0 * rho)  # measured 0.064 rad (mean 0.029)
    assert np.abs(vk.levels(level, x, y, z, D, D, D, 0.0)).max() * ramp < 3.0 * D * D / (8.0 * rho)


def test_normals_of_a_block_of_a_gentle_plane_are_exact() -> None:
    geometry = VoxelGeometry((0.0, 20 * D, 0.0), (D, D, D), (20, 20, 20))
    rows, cols = np.mgrid[0:20, 0:20]
    sx, sy = 0.15, -0.1  # dh/dx, dh/dy (y south)
    h = 20.0 + sx * cols * D + sy * rows * D
    level = density_block(h, geometry).astype(np.float32)
    # trilinear interpolation of f = (h − z)/dz is exact where none of the 8 voxels around the
    # point is clipped to ±1: here 0.25 voxel from a layer centre at most, the point lies 0.66
    # and 0.67 voxel above the centre below it
    x, y = np.array([11.3, 17.0]), np.array([13.7, 22.1])
    z = 20.0 + sx * x + sy * y
    expected = np.array([-sx, -sy, 1.0]) / math.sqrt(1.0 + sx * sx + sy * sy)
    assert vk.normals(level, x, y, z, D, D, D, 0.0) == pytest.approx(np.tile(expected, (2, 1)), abs=1e-6)


def test_the_ground_mesh_is_closed_and_encloses_the_matter() -> None:
    geometry, h = _block((12, 14), 16)
    density = DensityVoxels(geometry, density_block(h, geometry))
    mesh = ground_mesh(density)
    assert_watertight(mesh.faces)
    # marching cubes interpolates f linearly along the columns' edges as the matter does; only
    # at the sides, in the voxel layer of the surface, the mesh runs from the border centres to
    # the padding's −1 across a half voxel: it may miss at most that strip
    strip = 2 * (12 + 14) * D * (D / 2) * D
    assert 0.0 <= density.matter() - enclosed_volume(mesh) < strip
    assert mesh.vertices[:, 2].max() == pytest.approx(h.max(), abs=0.05)
    binary = BinaryVoxels(geometry, binary_block(h, geometry))
    assert_watertight(ground_mesh(binary).faces)


def test_the_mesh_of_a_voxelised_sphere_has_outward_vertex_normals() -> None:
    n = 16
    geometry = VoxelGeometry((0.0, n * D, 0.0), (D, D, D), (n, n, n))
    rows, cols, layers = np.indices(geometry.shape)
    centre = np.array([7.5, 7.5, 8.0]) * D  # x, y (grid coordinates), z
    p = np.stack([cols * D, rows * D, (layers + 0.5) * D], axis=-1)
    f = np.clip((5.0 * D - np.linalg.norm(p - centre, axis=-1)) / (2.0 * D), -1.0, 1.0)
    mesh = ground_mesh(DensityVoxels(geometry, f))
    normals = vertex_normals(mesh.vertices, mesh.faces)
    # the mesh's x east, y north from the grid's south-west corner: the centre's y flips
    radial = mesh.vertices - np.array([centre[0] + D / 2, n * D - centre[1] - D / 2, centre[2]])
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert np.einsum("ij,ij->i", normals, radial).min() > 0.95  # within 18° of radial everywhere
