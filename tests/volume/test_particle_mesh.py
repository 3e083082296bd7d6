"""Surface meshes of particle rocks: the volume they enclose against the solid's (analytic), a
closed surface (edges shared by two faces), the ground plane, smoothing and layer colours."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest
from tests.volume.conftest import assert_watertight, jittered_lattice

from unerode_cli.volume.mesh import PALETTE, Mesh, MeshExtraMissing, enclosed_volume, surface_mesh
from unerode_cli.volume.particle_surface import particle_mesh

SPACING = 0.5
RADIUS = 10.0
CENTRE = np.array([11.0, 11.0, 11.0])


@pytest.fixture(scope="module")
def sphere() -> np.ndarray:
    """About 33 000 particles of a 10 m ball (20 spacings of radius)."""
    points = jittered_lattice((44, 44, 44), SPACING)
    return points[np.linalg.norm(points - CENTRE, axis=1) < RADIUS]


def test_a_ball_of_particles_gives_a_closed_sphere_of_its_volume(sphere: np.ndarray) -> None:
    assert 2e4 < len(sphere) < 5e4
    mesh = particle_mesh(sphere, np.zeros(len(sphere), dtype=int), SPACING**3, SPACING, smoothing=0)
    assert_watertight(mesh.faces)
    assert enclosed_volume(mesh) == pytest.approx(4.0 / 3.0 * math.pi * RADIUS**3, rel=0.05)
    radius = np.linalg.norm(mesh.vertices - CENTRE, axis=1)
    assert np.all(np.abs(radius - RADIUS) < 2 * SPACING)


def test_smoothing_keeps_the_volume_and_rounds_the_sphere(sphere: np.ndarray) -> None:
    materials = np.zeros(len(sphere), dtype=int)
    raw = particle_mesh(sphere, materials, SPACING**3, SPACING, smoothing=0)
    smooth = particle_mesh(sphere, materials, SPACING**3, SPACING, smoothing=20)
    assert_watertight(smooth.faces)
    assert enclosed_volume(smooth) == pytest.approx(4.0 / 3.0 * math.pi * RADIUS**3, rel=0.05)
    deviation = [np.mean(_normal_deviation(m)) for m in (raw, smooth)]  # degrees from the radius
    assert deviation[0] < 6.0 and deviation[1] < 0.85 * deviation[0]


def _normal_deviation(mesh: Mesh) -> np.ndarray:
    """Angle (degrees) of each face's normal from the sphere's radius through its centroid."""
    corners = mesh.vertices[mesh.faces]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    radial = corners.mean(axis=1) - CENTRE
    cosine = np.einsum("ij,ij->i", normal, radial) / (np.linalg.norm(normal, axis=1)
                                                      * np.linalg.norm(radial, axis=1))
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


@pytest.mark.parametrize("smoothing", [0, 5])
def test_a_box_on_the_ground_is_closed_by_the_ground_plane(smoothing: int) -> None:
    size = np.array([15.0, 12.0, 8.0])
    points = jittered_lattice((30, 24, 16), SPACING, seed=1)
    mesh = particle_mesh(points, np.zeros(len(points), dtype=int), SPACING**3, SPACING, smoothing, ground=0.0)
    assert_watertight(mesh.faces)
    assert enclosed_volume(mesh) == pytest.approx(float(np.prod(size)), rel=0.05)
    assert mesh.vertices[:, 2].min() == 0.0
    assert mesh.vertices[:, 2].max() == pytest.approx(size[2], abs=SPACING)
    assert np.all(np.abs(mesh.vertices[:, :2].min(axis=0)) < SPACING)
    assert np.all(np.abs(mesh.vertices[:, :2].max(axis=0) - size[:2]) < SPACING)
    bottom = mesh.vertices[:, 2] == 0.0
    inner = np.all((mesh.vertices[:, :2] > 2.0) & (mesh.vertices[:, :2] < size[:2] - 2.0), axis=1)
    assert np.count_nonzero(bottom & inner) > 100  # the floor is a face of the mesh, not left open


def test_the_layers_of_a_block_colour_its_vertices() -> None:
    points = jittered_lattice((24, 16, 20), SPACING, seed=2)  # 12 × 8 × 10 m
    layer = np.where(points[:, 2] < 5.0, 0, 3)
    mesh = particle_mesh(points, layer, SPACING**3, SPACING, ground=0.0)
    upper, lower = mesh.vertices[:, 2] > 6.0, mesh.vertices[:, 2] < 4.0
    assert upper.sum() > 100 and lower.sum() > 100
    assert np.all(mesh.materials[upper] == 3) and np.all(mesh.materials[lower] == 0)
    assert np.all(mesh.colours[upper] == PALETTE[3]) and np.all(mesh.colours[lower] == PALETTE[0])


def test_the_enclosed_volume_of_a_cube_far_from_the_origin() -> None:
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    # 12 triangles, counter-clockwise seen from outside (index = 4x + 2y + z)
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    vertices = 2.0 * corners + np.array([5e5, 5e6, 1500.0])
    mesh = Mesh(vertices, faces, np.zeros(8, dtype=np.int16), np.zeros((8, 3), dtype=np.uint8))
    assert_watertight(faces)
    assert enclosed_volume(mesh) == pytest.approx(8.0, rel=1e-9)
    inside_out = Mesh(vertices, faces[:, ::-1], mesh.materials, mesh.colours)
    assert enclosed_volume(inside_out) == pytest.approx(-8.0)


def test_a_density_below_the_level_everywhere_gives_an_empty_mesh() -> None:
    mesh = surface_mesh(np.full((4, 4, 4), 0.2, dtype=np.float32), (0.0, 0.0, 0.0), 1.0, 0.5)
    assert len(mesh.vertices) == 0 and enclosed_volume(mesh) == 0.0


def test_without_scikit_image_the_error_says_which_extra_to_install(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "skimage.measure", None)
    with pytest.raises(MeshExtraMissing, match=r"pip install 'unerode-cli\[mesh\]'"):
        surface_mesh(np.zeros((4, 4, 4), dtype=np.float32), (0.0, 0.0, 0.0), 1.0)
