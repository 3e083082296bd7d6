"""Wind abrasion (002 Eq. 8) with the ray shelter model: boxes in a west wind."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from unerode_cli.sandstone import surface, wind
from unerode_cli.sandstone.sampling import Lattice, sample

SIDE = 16.0  # box edge (m), lattice spacing 1 m
K_A = 1e-3  # s²/m²
SPEED = 10.0  # m/s
UPWIND = (4.0, 4.0)  # low corner (x, y) of the upwind box
SHELTERED = (36.0, 4.0)  # downwind of it, 16 m behind
OPEN = (4.0, 24.0)  # beside it, in the open


class Boxes:
    def __init__(self, corners: list[tuple[float, float]]) -> None:
        self.corners = corners

    def contains(self, points: np.ndarray) -> np.ndarray:
        inside = np.zeros(len(points), dtype=bool)
        for x, y in self.corners:
            inside |= ((points[:, 0] > x) & (points[:, 0] < x + SIDE) & (points[:, 1] > y)
                       & (points[:, 1] < y + SIDE) & (points[:, 2] < SIDE))
        return inside



@pytest.fixture(scope="module")
def scene():
    """Three 16 m boxes on the ground, their surface and normals."""
    lattice = Lattice((0.0, 0.0, 0.0), (56.0, 44.0, 24.0), 1.0)
    positions = sample(Boxes([UPWIND, SHELTERED, OPEN]), lattice, seed=5)
    grid = lattice.surface_grid()
    on_surface = surface.surface_particles(positions, grid)
    return positions, grid, on_surface, surface.normals(positions, on_surface, grid)


def _face(positions, on_surface, corner, side):
    """Surface particles of a box's west (``side`` = 0) or east (1) face, 5 m from its edges."""
    x, y = corner
    face_x = x + side * SIDE
    return (on_surface & (np.abs(positions[:, 0] - face_x) < 0.8)
            & (np.abs(positions[:, 1] - y - SIDE / 2) < 3.0)
            & (positions[:, 2] > 5.0) & (positions[:, 2] < SIDE - 5.0))


def _rate(scene, params, seed=1, frame=0):
    positions, grid, on_surface, normals = scene
    return wind.abrasion_rate(positions, normals, on_surface, grid, np.full(len(positions), K_A), params,
                              seed, frame)


def test_the_wind_direction_reads_as_where_it_comes_from():
    assert np.allclose(wind.WindParams(azimuth=270.0).blowing, [1.0, 0.0, 0.0])
    assert np.allclose(wind.WindParams(azimuth=0.0, elevation=30.0).blowing,
                       [0.0, -math.cos(math.radians(30.0)), -0.5])
    assert np.allclose(wind.WindParams(direction=(0.0, 2.0, 0.0)).blowing, [0.0, 1.0, 0.0])
    rays = wind.cone_rays(wind.WindParams(azimuth=270.0, cone_angle=10.0, rays=32), seed=1, frame=3)
    assert np.allclose(np.linalg.norm(rays, axis=1), 1.0)
    assert np.degrees(np.arccos(-rays[:, 0])).max() < 10.0


def test_a_windward_face_erodes_at_k_a_u2_and_a_leeward_face_not_at_all(scene):
    positions, _, on_surface, _ = scene
    rate = _rate(scene, wind.WindParams(azimuth=270.0, speed=SPEED))
    windward = _face(positions, on_surface, OPEN, 0)
    leeward = _face(positions, on_surface, OPEN, 1)
    assert windward.sum() > 20 and leeward.sum() > 20
    assert np.median(rate[windward]) == pytest.approx(K_A * SPEED**2, rel=0.01)
    assert rate[windward].min() > 0.95 * K_A * SPEED**2
    assert not rate[leeward].any()
    # the top face lies along the wind: (−n·v)₊ ≈ 0
    top = on_surface & (positions[:, 2] > SIDE - 0.8) & (np.abs(positions[:, 0] - OPEN[0] - SIDE / 2) < 3.0)
    assert rate[top].max() < 0.1 * K_A * SPEED**2


def test_a_box_in_the_lee_of_another_erodes_less_unless_the_rays_stop_short(scene):
    positions, _, on_surface, _ = scene
    sheltered = _face(positions, on_surface, SHELTERED, 0)
    upwind = _face(positions, on_surface, UPWIND, 0)
    rate = _rate(scene, wind.WindParams(azimuth=270.0, speed=SPEED))
    assert rate[sheltered].mean() < 0.1 * rate[upwind].mean()
    assert rate[upwind].mean() == pytest.approx(K_A * SPEED**2, rel=0.01)
    # with rays shorter than the 16 m gap, the upwind box shelters nothing
    short = _rate(scene, wind.WindParams(azimuth=270.0, speed=SPEED, ray_length=10.0))
    assert short[sheltered].mean() == pytest.approx(K_A * SPEED**2, rel=0.01)


def test_abrasion_is_identical_on_one_and_two_threads(scene, threads):
    params = wind.WindParams(azimuth=250.0, elevation=10.0, speed=SPEED, cone_angle=20.0)
    runs = []
    for n in (1, 2):
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
        runs.append(_rate(scene, params, seed=4, frame=7))
    assert np.array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0], _rate(scene, params, seed=4, frame=8))


def _faces(positions, on_surface, corner):
    """Surface particles of a box's west, east, south and north faces, 5 m from their edges."""
    x, y = corner
    middle = (positions[:, 2] > 5.0) & (positions[:, 2] < SIDE - 5.0) & on_surface
    along_y = np.abs(positions[:, 1] - y - SIDE / 2) < 3.0
    along_x = np.abs(positions[:, 0] - x - SIDE / 2) < 3.0
    return [middle & along_y & (np.abs(positions[:, 0] - x - s * SIDE) < 0.8) for s in (0, 1)] + \
           [middle & along_x & (np.abs(positions[:, 1] - y - s * SIDE) < 0.8) for s in (0, 1)]


def test_a_wind_rose_cuts_every_face_it_names_by_its_share_of_the_time(scene):
    """The rose west 1/2, east 1/4, north 1/4 (south: none): the open box's faces erode at
    k_a·U² times their shares (west 0.5, east 0.25, north 0.25, south 0) within 5 %, as the
    time-weighted sum of the single winds (to rounding)."""
    positions, _, on_surface, _ = scene
    rose = wind.WindParams(speed=SPEED, rose=((270.0, 2.0), (90.0, 1.0), (0.0, 1.0)))
    rate = _rate(scene, rose)
    singles = sum(share * _rate(scene, wind.WindParams(speed=SPEED, azimuth=azimuth))
                  for azimuth, share in ((270.0, 0.5), (90.0, 0.25), (0.0, 0.25)))
    np.testing.assert_allclose(rate, singles, rtol=1e-12, atol=1e-15)
    west, east, south, north = (rate[face].mean() for face in _faces(positions, on_surface, OPEN))
    full = K_A * SPEED**2
    assert [west / full, east / full, north / full] == pytest.approx([0.5, 0.25, 0.25], rel=0.05)
    assert south == 0.0


def test_a_rose_needs_positive_weights():
    with pytest.raises(ValueError, match="weight > 0"):
        wind.WindParams(rose=((270.0, 0.0),))
