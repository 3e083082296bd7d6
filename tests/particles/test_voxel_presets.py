"""The presets of 003 Table 1 that need a 3D terrain make what 003 §5 says they make: the coastal
preset on density voxels undercuts a cliff at sea level (overhangs), the tunnel preset drills
from its source through a rock wall to the other side, and the karst preset on binary voxels
dissolves the soft layer more than the hard rock around it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from unerode_cli.particles import (
    BinaryTerrain,
    DensityTerrain,
    Emission,
    Material,
    VelocityField,
    get_preset,
    run,
)
from unerode_cli.volume.voxels import (
    BinaryVoxels,
    DensityVoxels,
    VoxelGeometry,
    binary_block,
    density_block,
    horizon_material,
)


def _overhangs(solid: np.ndarray) -> np.ndarray:
    """bool[rows, columns, layers]: empty voxels with ground somewhere above them in their column."""
    ground_above = np.flip(np.logical_or.accumulate(np.flip(solid, axis=2), axis=2), axis=2)
    return ~solid[:, :, :-1] & ground_above[:, :, 1:]


def test_the_coastal_preset_undercuts_a_cliff_at_sea_level() -> None:
    d, sea = 10.0, 80.0  # 10 m voxels (003 Table 1 Coastal), sea level (m)
    geometry = VoxelGeometry((0.0, 32 * d, 0.0), (d, d, d), (32, 48, 24))
    x = np.arange(48) * d
    h = np.broadcast_to(np.where(x < 240.0, 30.0, 170.0), (32, 48))  # sea floor, then a cliff to the east
    terrain = DensityTerrain(DensityVoxels(geometry, density_block(h, geometry)))
    params = get_preset("coastal").params(d)
    waves = VelocityField.uniform(0.5, 0.0, medium="water")  # towards the coast, in the sea only
    result = run(terrain, params, Emission.rain(80, mask=h < sea), iterations=3, seed=1, velocity=waves,
                 sea_level=sea)
    before, after = terrain.voxels.density, result.terrain.voxels.density
    assert not _overhangs(before > 0).any()
    holes = _overhangs(after > 0)
    assert np.count_nonzero(holes.any(axis=2)) > 100  # columns with ground above empty voxels (measured 207)
    loss = np.clip(before - after, 0.0, None).sum(axis=(0, 1))  # matter taken, per layer
    centroid = (geometry.layer_centres() * loss).sum() / loss.sum()
    assert centroid == pytest.approx(sea, abs=0.5 * params.radius)  # a notch at sea level (measured 77.5 m)
    assert np.all(result.dh[:, x >= 320.0] == 0.0)  # the cliff top stands above the notch
    b = result.budget
    assert b.suspended > 0.5 * b.detached  # corrosion: what is dissolved stays in the sea


def test_the_tunnel_preset_drills_through_a_rock_wall() -> None:
    d = 1.0  # 1 m voxels, 003 Table 1 Tunnel
    rows, cols, layers = 24, 64, 44
    geometry = VoxelGeometry((0.0, rows * d, 0.0), (d, d, d), (rows, cols, layers))
    x = np.arange(cols) * d
    h = np.tile(34.0 - 0.3 * x, (rows, 1))  # a slope down to the east ...
    wall = slice(28, 36)
    h[:, wall] = 38.0  # ... across which stands a wall 8 m thick, 14 m above the slope's foot
    terrain = DensityTerrain(DensityVoxels(geometry, density_block(h, geometry)))
    params = get_preset("tunnel").params(d, drop_height=3.0)
    # runoff from a spring in the slope 2 m west of the wall, flowing east at 6.7 m/s
    source = Emission.source(100, (26.0, (rows - 1) / 2.0), spread=params.radius, velocity=(6.7, 0.0, 0.0))
    result = run(terrain, params, source, iterations=20, seed=1)
    air = result.terrain.voxels.density <= 0.0
    below_top = air[:, 27:37, :36]  # the wall and a voxel either side, below the wall's top voxels
    labels, _ = ndimage.label(below_top)
    west, east = set(np.unique(labels[:, 0])) - {0}, set(np.unique(labels[:, -1])) - {0}
    through = west & east
    assert through  # a passage of air from one side of the wall to the other
    passage = np.isin(labels, list(through))
    ground = ~air[:, 27:37, :]
    rock_above = np.flip(np.logical_or.accumulate(np.flip(ground, axis=2), axis=2), axis=2)[:, :, 1:37]
    roofed = passage & rock_above
    assert np.count_nonzero(roofed.any(axis=(0, 2))) >= 5  # under rock along most of it (measured 9 of 10)


def test_the_karst_preset_dissolves_the_soft_layer_more() -> None:
    d, table = 2.0, 40.0  # 2 m voxels (003 Table 1 Karst), water table (m)
    geometry = VoxelGeometry((0.0, 32 * d, 0.0), (d, d, d), (32, 48, 40))
    x = np.arange(48) * d
    h = np.broadcast_to(np.where(x < 20.0, 30.0, 60.0), (32, 48))  # a flooded gorge along a plateau
    soft, hard = Material("limestone", 5.0), Material("marl", 0.5)
    layers = horizon_material(geometry, np.array([table - 8.0, table, np.inf]), np.array([1, 0, 1]))
    terrain = BinaryTerrain(BinaryVoxels(geometry, binary_block(h, geometry), material=layers), [soft, hard])
    params = get_preset("karst").params(d)
    flow = VelocityField.uniform(1.0, 0.0, medium="water")  # groundwater flowing into the plateau
    result = run(terrain, params, Emission.rain(500, mask=h < table), iterations=10, seed=1, velocity=flow,
                 sea_level=table)
    solid0, solid1 = terrain.voxels.solid, result.terrain.voxels.solid
    removed = solid0 & ~solid1
    z = geometry.layer_centres()
    near = np.abs(z - table) < 2.0 * params.radius  # what the floating particles reach
    in_soft = near & (layers[0, 0] == 0)
    in_hard = near & (layers[0, 0] == 1)
    share = [removed[:, :, s].sum() / solid0[:, :, s].sum() for s in (in_soft, in_hard)]
    assert share[0] > 3.0 * share[1] > 0.0  # measured 21 % against 3 % of the rock
    assert removed.sum() * geometry.voxel_volume < result.budget.detached  # dissolved, not more
