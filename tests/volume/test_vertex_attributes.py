"""Vertex values taken from the nearest particle, checked against a brute-force search."""

import numpy as np
import pytest

from unerode_cli.volume.vertex_attributes import nearest_particle, vertex_values


def test_nearest_particle_matches_brute_force():
    rng = np.random.default_rng(3)
    positions = rng.uniform(0.0, 10.0, (500, 3))
    vertices = rng.uniform(-1.0, 11.0, (300, 3))
    brute = np.argmin(((vertices[:, None, :] - positions[None, :, :]) ** 2).sum(axis=2), axis=1)
    assert np.array_equal(nearest_particle(vertices, positions), brute)


def test_vertex_values_carry_each_property_as_float32():
    positions = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    vertices = np.array([[1.0, 0.5, 0.0], [9.2, -0.3, 0.1], [4.9, 0.0, 0.0]])
    values = vertex_values(vertices, positions, {"stress": np.array([1.5, -2.25]), "layer": np.array([0, 3])})
    assert values["stress"].dtype == np.float32
    np.testing.assert_array_equal(values["stress"], [1.5, -2.25, 1.5])
    np.testing.assert_array_equal(values["layer"], [0.0, 3.0, 0.0])


def test_no_particle_is_refused():
    with pytest.raises(ValueError, match="no particle"):
        nearest_particle(np.zeros((2, 3)), np.zeros((0, 3)))
    assert nearest_particle(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)
