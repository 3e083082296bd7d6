"""Taubin smoothing: the averaging operator, a noisy sphere's volume (against plain Laplacian
smoothing, which shrinks it), and vertices held on the ground."""

from __future__ import annotations

import numpy as np
import pytest
from tests.volume.conftest import assert_watertight

from unerode_cli.volume.mesh import Mesh, enclosed_volume, surface_mesh
from unerode_cli.volume.smoothing import taubin_smooth, umbrella_operator


def _unit_sphere() -> Mesh:
    """The zero level of the analytic field 1 − |x| (marching cubes, 0.1 nodes)."""
    x = (np.indices((41, 41, 41)) - 20) * 0.1
    return surface_mesh((1.0 - np.sqrt((x**2).sum(axis=0))).astype(np.float32), (-2.0, -2.0, -2.0), 0.1, 0.0)


def _volume(mesh: Mesh, vertices: np.ndarray) -> float:
    return enclosed_volume(Mesh(vertices, mesh.faces, mesh.materials, mesh.colours))


def test_the_umbrella_operator_averages_the_neighbours() -> None:
    faces = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])  # a tetrahedron
    average = umbrella_operator(faces, 5).toarray()  # vertex 4 is in no face
    assert np.allclose(average[:4, :4], (1.0 - np.eye(4)) / 3.0) and np.all(average[4] == 0.0)
    assert average.shape == (5, 5)


def test_taubin_smoothing_removes_noise_and_keeps_the_volume() -> None:
    sphere = _unit_sphere()
    assert_watertight(sphere.faces)
    assert enclosed_volume(sphere) == pytest.approx(4.0 / 3.0 * np.pi, rel=0.01)
    rng = np.random.default_rng(0)
    noisy = sphere.vertices * (1.0 + rng.uniform(-0.03, 0.03, (len(sphere.vertices), 1)))
    smooth = taubin_smooth(noisy, sphere.faces, 10)
    spread = [np.std(np.linalg.norm(v, axis=1)) for v in (noisy, smooth)]
    assert spread[1] < 0.5 * spread[0]
    assert _volume(sphere, smooth) == pytest.approx(_volume(sphere, noisy), rel=0.01)
    shrunk = noisy.copy()  # plain Laplacian smoothing, λ steps only
    average = umbrella_operator(sphere.faces, len(noisy))
    for _ in range(10):
        shrunk += 0.5 * (average @ shrunk - shrunk)
    assert _volume(sphere, shrunk) < 0.97 * _volume(sphere, noisy)


def test_held_vertices_keep_their_height() -> None:
    sphere = _unit_sphere()
    held = sphere.vertices[:, 2] < -0.5
    smooth = taubin_smooth(sphere.vertices, sphere.faces, 5, held)
    assert np.array_equal(smooth[held, 2], sphere.vertices[held, 2])
    assert np.abs(smooth[~held] - sphere.vertices[~held]).max() > 1e-3
