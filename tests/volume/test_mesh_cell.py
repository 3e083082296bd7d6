"""Meshes of particle rocks at cells finer and coarser than the particle spacing s: a ball's
volume against its particles' (a conservation law), the vertex count against the cell (a
surface sampled at spacing c has about 1/c² vertices), thick rock meshed from its blurred
density alone, and sheets and rods one or two particles thick carrying load between two
pillars: one closed piece, about as thick as the particles and where they are."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from tests.volume.conftest import assert_watertight, jittered_lattice

from unerode_cli.volume import density
from unerode_cli.volume.mesh import Mesh, enclosed_volume
from unerode_cli.volume.particle_surface import particle_mesh

SPACING = 0.5
#: The arch: two pillars 4 × 4 × 20 spacings at x cells [0, 4) and [16, 20), y cells [0, 4),
#: joined on top (z cells from 20) by a sheet or a rod spanning 12 spacings of air.
PILLAR, SPAN, HEIGHT, WIDTH = 4, 20, 20, 4
MID_SPAN = (SPAN / 2 * SPACING, WIDTH / 2 * SPACING)  # (x, y) of the sheet's middle (m)


def arch(layers: int = 1, rod: bool = False, seed: int = 0) -> np.ndarray:
    """The arch's particles (m) on a jittered lattice, standing on the ground z = 0: the sheet
    ``layers`` particles thick, or a rod one particle thick along x (y cell 1)."""
    points = jittered_lattice((SPAN, WIDTH, HEIGHT + layers), SPACING, seed=seed)
    i, j, k = np.floor(points / SPACING).astype(int).T
    pillars = ((i < PILLAR) | (i >= SPAN - PILLAR)) & (k < HEIGHT)
    top = (k >= HEIGHT) & ((j == 1) if rod else True)
    return points[pillars | top]


def pieces(mesh: Mesh) -> int:
    """Connected pieces of a mesh: components of its vertices joined by its edges."""
    edges = np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]]])
    n = len(mesh.vertices)
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[0]


def vertical_crossings(mesh: Mesh, x: float, y: float) -> np.ndarray:
    """Heights (m, sorted) where the vertical line through (x, y) crosses the mesh's faces."""
    a, b, c = (mesh.vertices[mesh.faces[:, n]] for n in range(3))

    def side(p: np.ndarray, q: np.ndarray) -> np.ndarray:  # twice the signed area of (p, q, (x, y))
        return (q[:, 0] - p[:, 0]) * (y - p[:, 1]) - (q[:, 1] - p[:, 1]) * (x - p[:, 0])

    w = np.column_stack([side(b, c), side(c, a), side(a, b)])
    area = w.sum(axis=1)
    hit = (np.all(w >= 0, axis=1) | np.all(w <= 0, axis=1)) & (area != 0)
    z = (w[hit, 0] * a[hit, 2] + w[hit, 1] * b[hit, 2] + w[hit, 2] * c[hit, 2]) / area[hit]
    return np.sort(z)


def top_extent(mesh: Mesh, y: float = MID_SPAN[1]) -> tuple[float, float]:
    """The medians over five points along the middle of the span, at ``y`` (m), of the
    vertical extent (m) of the mesh above the pillars' mid-height and of its mid-height (m)."""
    extents, middles = [], []
    for x in MID_SPAN[0] + SPACING * np.linspace(-2.0, 2.0, 5):
        z = vertical_crossings(mesh, x + 1e-3, y + 2e-3)
        z = z[z > HEIGHT * SPACING / 2]
        extents.append(z.max() - z.min() if len(z) >= 2 else 0.0)
        if len(z) >= 2:
            middles.append((z.max() + z.min()) / 2)
    return float(np.median(extents)), float(np.median(middles)) if middles else math.nan


@pytest.fixture(scope="module")
def ball() -> np.ndarray:
    """About 33 000 particles of a ball of radius 20 spacings (10 m)."""
    points = jittered_lattice((44, 44, 44), SPACING)
    return points[np.linalg.norm(points - 11.0, axis=1) < 10.0]


@pytest.mark.parametrize("cell", [SPACING / 2, SPACING, 2 * SPACING])
def test_a_ball_keeps_its_particles_volume_at_any_cell(ball: np.ndarray, cell: float) -> None:
    mesh = particle_mesh(ball, np.zeros(len(ball), dtype=int), SPACING**3, cell, smoothing=0)
    assert_watertight(mesh.faces)
    assert enclosed_volume(mesh) == pytest.approx(len(ball) * SPACING**3, rel=0.03)
    radius = np.linalg.norm(mesh.vertices - 11.0, axis=1)
    assert np.all(np.abs(radius - 10.0) < max(cell, SPACING))


def test_the_vertex_count_goes_as_one_over_the_cell_squared(ball: np.ndarray) -> None:
    materials = np.zeros(len(ball), dtype=int)
    counts = {cell: len(particle_mesh(ball, materials, SPACING**3, cell).vertices)
              for cell in (SPACING / 2, SPACING, 2 * SPACING)}
    assert counts[SPACING / 2] / counts[SPACING] == pytest.approx(4.0, rel=0.4)
    assert counts[SPACING] / counts[2 * SPACING] == pytest.approx(4.0, rel=0.4)
    sheet = arch()
    finer, coarser = (len(particle_mesh(sheet, np.zeros(len(sheet), dtype=int), SPACING**3, cell,
                                        ground=0.0).vertices) for cell in (SPACING / 2, SPACING))
    assert finer / coarser == pytest.approx(4.0, rel=0.4)


@pytest.mark.parametrize("cell", [SPACING / 2, SPACING, 2 * SPACING])
def test_thick_rock_is_meshed_from_its_blurred_density_alone(ball: np.ndarray, cell: float,
                                                             monkeypatch) -> None:
    box = jittered_lattice((30, 24, 16), SPACING, seed=1)
    for points, ground in ((ball, None), (box, 0.0)):
        materials = np.zeros(len(points), dtype=int)
        field = density.particle_density(points, materials, SPACING**3, cell, ground=ground).values
        with monkeypatch.context() as patch:
            patch.setattr(density, "MIN_FEATURE", 10**12)  # no thin feature is kept
            blurred = density.particle_density(points, materials, SPACING**3, cell, ground=ground).values
        np.testing.assert_array_equal(field, blurred)


@pytest.mark.parametrize("layers", [1, 2])
@pytest.mark.parametrize("cell", [SPACING / 2, SPACING, 2 * SPACING])
def test_a_sheet_carrying_load_is_one_closed_piece_as_thick_as_it(layers: int, cell: float) -> None:
    """About as thick as the sheet's particles: at least 90 % of it, at most one cell or half a
    spacing more (the particles' jitter) than it or than a cell. At cell = s the sheet lies
    halfway between two node layers (nodes from the ground)."""
    points = arch(layers)
    mesh = particle_mesh(points, np.zeros(len(points), dtype=int), SPACING**3, cell, ground=0.0)
    assert_watertight(mesh.faces)
    assert pieces(mesh) == 1  # the pillars hold the sheet
    thickness, middle = top_extent(mesh)
    sheet = layers * SPACING
    assert 0.9 * sheet <= thickness <= max(sheet, cell) + max(cell, SPACING / 2)
    assert middle == pytest.approx(points[points[:, 2] > HEIGHT * SPACING, 2].mean(), abs=SPACING / 2)


@pytest.mark.parametrize("cell", [SPACING / 2, SPACING])
def test_a_rod_one_particle_thick_carrying_load_is_one_piece(cell: float) -> None:
    points = arch(rod=True)
    mesh = particle_mesh(points, np.zeros(len(points), dtype=int), SPACING**3, cell, ground=0.0)
    assert_watertight(mesh.faces)
    assert pieces(mesh) == 1
    thickness, _ = top_extent(mesh, 1.5 * SPACING)  # along the rod's axis
    assert 0.9 * SPACING <= thickness <= SPACING + max(cell, SPACING / 2)


def test_the_blur_alone_drops_a_sheet_one_particle_thick(monkeypatch) -> None:
    """What the thin features are for: without them the sheet is gone and the pillars stand
    apart, as the blurred density of a sheet one particle thick peaks below ½."""
    monkeypatch.setattr(density, "MIN_FEATURE", 10**12)
    points = arch()
    mesh = particle_mesh(points, np.zeros(len(points), dtype=int), SPACING**3, SPACING, ground=0.0)
    assert pieces(mesh) == 2
    assert top_extent(mesh)[0] == 0.0


def test_a_row_on_a_face_is_left_to_the_blur_and_loose_grains_are_dropped() -> None:
    """Four particles in a row lying on a block's top face stay within one spacing of the block:
    the blur keeps them, a bump of their volume (the presence's cubes, closed, would make it
    5.5 particle volumes). Three loose grains in a row are fewer than ``MIN_FEATURE``: the mesh
    drops them as the blur does."""
    block = (np.indices((20, 12, 12)).reshape(3, -1).T + 0.5) * SPACING  # 10 × 6 × 6 m
    row = np.column_stack([SPACING * (np.arange(4) + 8.5), np.full(4, 3.25), np.full(4, 6.25)])
    grains = np.array([[2.25, 3.25, 9.25], [2.75, 3.25, 9.25], [3.25, 3.25, 9.25]])
    points = np.concatenate([block, row, grains])
    materials = np.zeros(len(points), dtype=int)
    mesh = particle_mesh(points, materials, SPACING**3, SPACING / 2, smoothing=0)
    alone = particle_mesh(block, materials[:len(block)], SPACING**3, SPACING / 2, smoothing=0)
    assert pieces(mesh) == 1
    gained = (enclosed_volume(mesh) - enclosed_volume(alone)) / SPACING**3
    assert gained == pytest.approx(len(row), rel=0.1)
