"""The wind around the rock (002 §5): the lattice Boltzmann flow against a sphere's drag and
wake, and the abrasion its local wind gives a block (speed-up, wake, recirculation)."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.sandstone import surface, wind
from unerode_cli.sandstone.airflow import Airflow, flow_through_steps
from unerode_cli.sandstone.sampling import Lattice, sample
from unerode_cli.sandstone.wind_flow import FlowWind, FlowWindParams, flow_abrasion

K_A, SPEED = 1e-3, 10.0


class _Block:
    """An 8 m cube on the ground, from (8, 8) to (16, 16) m."""

    @staticmethod
    def contains(points: np.ndarray) -> np.ndarray:
        x, y, z = points.T
        return (x > 8) & (x < 16) & (y > 8) & (y < 16) & (z < 8)


@pytest.fixture(scope="module")
def block():
    lattice = Lattice((0.0, 0.0, 0.0), (24.0, 24.0, 12.0), 0.5)
    positions = sample(_Block(), lattice, seed=5)
    grid = lattice.surface_grid()
    on_surface = surface.surface_particles(positions, grid)
    normals = surface.normals(positions, on_surface, grid)
    flow = FlowWind(positions, np.array([1.0, 0.0, 0.0]), FlowWindParams(cells_across=10, reynolds=50.0))
    return positions, grid, on_surface, normals, flow


def _faces(positions, on_surface):
    x, y, z = positions.T
    middle = on_surface & (z > 2.0) & (z < 6.0)
    return {"west": middle & (np.abs(x - 8.0) < 0.6) & (np.abs(y - 12.0) < 3.0),
            "east": middle & (np.abs(x - 16.0) < 0.6) & (np.abs(y - 12.0) < 3.0)}


def test_the_flow_abrades_the_lee_face_that_rays_leave_untouched(block) -> None:
    """A west wind on the cube (Re = 50 on 10 cells): the windward face takes 0.3–1 × k_a·U²
    (grains from ~3 m upwind, slowed by the blocking; measured 0.42), the leeward face, in the
    recirculating wake, between 0.3 % and 10 % of the windward face's (0.6 %), where the rays give
    exactly 0; the flow speeds up past the cube (fastest air ≥ 1.2 × the free wind; 1.66)."""
    positions, grid, on_surface, normals, flow = block
    k_a = np.full(len(positions), K_A)
    by_flow = flow_abrasion(flow, positions, normals, on_surface, k_a, SPEED)
    by_rays = wind.abrasion_rate(positions, normals, on_surface, grid, k_a,
                                 wind.WindParams(azimuth=270.0, speed=SPEED), 1, 0)
    faces = _faces(positions, on_surface)
    west, east = (by_flow[faces[f]].mean() / (K_A * SPEED**2) for f in ("west", "east"))
    assert 0.3 < west < 1.0
    assert 0.003 * west < east < 0.1 * west
    assert by_rays[faces["east"]].max() == 0.0
    assert np.linalg.norm(flow.velocity, axis=-1).max() >= 1.2


def test_an_opened_cell_takes_the_free_wind() -> None:
    solid = np.zeros((12, 10, 8), dtype=bool)
    solid[4:7, 3:6, :4] = True
    flow = Airflow(solid, np.array([0.0, 1.0, 0.0]), reynolds=20.0, width=3.0)
    flow.run(50)
    opened = solid.copy()
    opened[5, 4, 3] = False
    flow.set_solid(opened)
    assert flow.velocity()[5, 4, 3] == pytest.approx([0.0, 1.0, 0.0], abs=1e-12)


@pytest.fixture(scope="module")
def sphere():
    """A sphere of 16 cells at Re = 100 in a domain of 8 × 5 × 5 diameters, after two crossings
    of the domain (8 minutes on two cores): (flow, centre, diameter, shape)."""
    diameter, shape = 16.0, (128, 80, 80)
    x, y, z = np.mgrid[0:shape[0], 0:shape[1], 0:shape[2]] + 0.5
    centre = (0.3 * shape[0], shape[1] / 2, shape[2] / 2)
    solid = (x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2 < (diameter / 2) ** 2
    flow = Airflow(solid, np.array([1.0, 0.0, 0.0]), reynolds=100.0, width=diameter)
    flow.run(2 * flow_through_steps(shape[0]))
    return flow, centre, diameter, shape


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="a staircase sphere: C_d 1.262 at 16 cells (+15.8 %), 1.306 at "
                   "10 (+20 %), falling with resolution; a curved boundary (interpolated bounce-back) "
                   "is not built")
def test_a_sphere_at_re_100_has_its_drag(sphere) -> None:
    """C_d within 15 % of 1.09 at Re = 100 (Clift, Grace & Weber 1978)."""
    flow, _, diameter, _ = sphere
    drag = flow.drag()[0] / (0.5 * flow.u_lattice**2 * np.pi * diameter**2 / 4)
    assert drag == pytest.approx(1.09, rel=0.15)


@pytest.mark.slow
def test_a_sphere_at_re_100_has_its_wake(sphere) -> None:
    """The recirculation behind the sphere within 25 % of 0.87 D at Re = 100 (Taneda 1956;
    measured 0.975 D, one cell being 0.06 D)."""
    flow, centre, diameter, shape = sphere
    axis = flow.velocity()[:, int(centre[1]), int(centre[2]), 0]
    behind = np.flatnonzero((np.arange(shape[0]) + 0.5 > centre[0] + diameter / 2) & (axis < 0))
    wake = (behind.max() + 1 - (centre[0] + diameter / 2)) / diameter
    assert wake == pytest.approx(0.87, rel=0.25)
