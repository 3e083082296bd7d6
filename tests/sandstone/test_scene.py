"""Scenes (002 §3.3): the CSG tree, layers, paint and noise, and the jittered-lattice sampling."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.sandstone import sampling
from unerode_cli.sandstone.presets import PRESETS, preset_scene
from unerode_cli.sandstone.sampling import (
    ExtrudedDem,
    Lattice,
    lattice_for,
    sample,
    scene_particles,
    top_surface,
)
from unerode_cli.sandstone.scene import parse_scene, value_noise

DOMAIN = {"size": [10.0, 10.0, 10.0]}


def _scene(shape: dict, **extra) -> object:
    return parse_scene({"domain": DOMAIN, "shape": shape, **extra})


def test_csg_operations_contain_the_right_points() -> None:
    box = {"box": {"min": [0, 0, 0], "max": [4, 4, 4]}}
    ball = {"sphere": {"centre": [4, 4, 4], "radius": 2}}
    points = np.array([[1.0, 1.0, 1.0], [3.5, 3.5, 3.5], [5.0, 4.0, 4.0], [8.0, 8.0, 8.0]])
    assert _scene({"union": [box, ball]}).shape.contains(points).tolist() == [True, True, True, False]
    assert _scene({"intersection": [box, ball]}).shape.contains(points).tolist() == [
        False, True, False, False]
    assert _scene({"difference": [box, ball]}).shape.contains(points).tolist() == [True, False, False, False]
    rod = _scene({"cylinder": {"base": [0, 5, 5], "radius": 1, "height": 6, "axis": "x"}}).shape
    inside = rod.contains(np.array([[5.9, 5.5, 5.5], [6.1, 5.0, 5.0], [3.0, 6.2, 5.0]]))
    assert inside.tolist() == [True, False, False]


@pytest.mark.parametrize("document, says", [
    ({"shape": {"pyramid": {"size": 3}}}, "unknown shape 'pyramid'"),
    ({"shape": {"box": {"min": [0, 0, 0], "max": [1, -1, 1]}}}, "positive sizes"),
    ({"shape": {"sphere": {"centre": [1, 1, 1], "radius": -2}}}, "radius"),
    ({"domain": {"size": [10, -1, 10]}, "shape": {"sphere": {"centre": [1, 1, 1], "radius": 1}}}, "positive"),
    ({"shape": {"sphere": {"centre": [1, 1, 1], "radius": 1}}, "layers": [{"top": 5}, {"top": 3}, {}]},
     "increase"),
    ({"shape": {"union": []}}, "non-empty list"),
    ({"shape": {"sphere": {"centre": [1, 1, 1], "radius": 1}}, "particles": 10, "cell_size": 1.0}, "either"),
])
def test_malformed_scenes_are_refused_in_one_sentence(document: dict, says: str) -> None:
    with pytest.raises(ValueError, match=says) as error:
        parse_scene({"domain": DOMAIN, **document})
    assert "\n" not in str(error.value)


def test_value_noise_is_smooth_bounded_and_keyed_by_the_seed_only() -> None:
    rng = np.random.default_rng(0)
    points = rng.uniform(0.0, 40.0, (20000, 3))
    noise = value_noise(points, 4.0, seed=7, octaves=2)
    assert noise.min() >= -1.0 and noise.max() <= 1.0
    assert abs(noise.mean()) < 0.05 and noise.std() > 0.2
    np.testing.assert_array_equal(value_noise(points[::-1], 4.0, seed=7, octaves=2), noise[::-1])
    near = value_noise(points + 0.1, 4.0, seed=7, octaves=2)
    assert np.corrcoef(noise, near)[0, 1] > 0.95  # smooth over a fortieth of the wavelength
    assert abs(np.corrcoef(noise, value_noise(points, 4.0, seed=8, octaves=2))[0, 1]) < 0.1


def test_sampling_puts_the_requested_count_one_per_lattice_cell(monkeypatch) -> None:
    scene = _scene({"difference": [{"box": {"min": [1, 1, 0], "max": [9, 9, 6]}},
                                   {"sphere": {"centre": [5, 5, 6], "radius": 3}}]})
    lattice, expected = lattice_for(scene.shape, scene.low, np.array(DOMAIN["size"]), 30000)
    positions = sample(scene.shape, lattice, seed=1)
    assert len(positions) == pytest.approx(30000, rel=0.03)
    assert expected == pytest.approx(30000, rel=1e-9)
    occupancy = lattice.surface_grid().occupancy(positions)
    assert occupancy.max() == 1 and occupancy.sum() == len(positions)
    offset = (positions - np.asarray(lattice.low)) / lattice.spacing % 1.0 - 0.5
    assert np.abs(offset).max() <= sampling.JITTER
    monkeypatch.setattr(sampling, "CHUNK_POINTS", 1000)
    np.testing.assert_array_equal(np.sort(sample(scene.shape, lattice, seed=1), axis=0),
                                  np.sort(positions, axis=0))


def test_layers_paint_and_noise_reach_the_particles() -> None:
    scene = _scene({"box": {"min": [0, 0, 0], "max": [10, 10, 10]}},
                   layers=[{"top": 3.0}, {"top": 7.0}, {}],
                   paint=[{"shape": {"box": {"min": [0, 0, 0], "max": [2, 10, 10]}}, "erodibility": 0.0,
                           "vegetation": 0.5}],
                   noise={"amplitude": 0.5, "wavelength": 2.0, "seed": 3})
    lattice = Lattice((0.0, 0.0, 0.0), (10.0, 10.0, 10.0), 0.5)
    particles = scene_particles(scene, lattice, seed=0)
    z, x = particles.positions[:, 2], particles.positions[:, 0]
    np.testing.assert_array_equal(particles.layer, np.where(z <= 3.0, 0, np.where(z <= 7.0, 1, 2)))
    assert np.all(particles.erodibility[x <= 2.0] == 0.0) and np.all(particles.vegetation[x <= 2.0] == 0.5)
    rest = particles.erodibility[x > 2.0]
    assert rest.min() >= np.exp(-0.5) and rest.max() <= np.exp(0.5) and rest.std() > 0.05


def test_an_extruded_dem_comes_back_as_its_top_surface() -> None:
    rng = np.random.default_rng(1)
    dem = 20.0 + rng.uniform(0.0, 5.0, (6, 8))
    dem[0, 0] = np.nan
    solid = ExtrudedDem(dem, (0.0, 0.0), 2.0, 2.0, base=10.0)
    low, size = np.array([0.0, 0.0, 10.0]), np.array([16.0, 12.0, 20.0])
    lattice, _ = lattice_for(solid, low, size, 40000)
    positions = sample(solid, lattice, seed=0)
    top = top_surface(positions, (0.0, 0.0), 2.0, 2.0, dem.shape, 10.0, lattice.spacing)
    valid = np.isfinite(dem)
    assert np.abs(top[valid] - dem[valid]).max() <= 1.5 * lattice.spacing
    assert top[0, 0] == 10.0  # nodata: no rock, the ground


#: 002 Table 1's particle numbers (arch = row 1, hoodoo = the mushroom of row 2); the canyon and
#: cave of Fig. 6 are not in the table and use 1 M.
TABLE1_PARTICLES = {"arch": 1_000_000, "hoodoo": 1_000_000, "arcade": 2_500_000, "alcove": 1_500_000,
                    "butte": 1_500_000, "canyon": 1_000_000, "cave": 1_000_000}


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_are_valid_scenes_with_table1_counts(name: str) -> None:
    scene = preset_scene(name)
    assert scene.particles == TABLE1_PARTICLES[name]
    assert [layer.top for layer in scene.layer_stack().layers][-1] == np.inf
