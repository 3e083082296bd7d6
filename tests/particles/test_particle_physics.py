"""One particle in still air above a flat plane: Stokes settling (003 Eq. 5–7) against the
analytic solution, and the bounce height against the coefficient of restitution."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.particles import Emission, HeightfieldTerrain, ParticleParams, run

DX = 20.0
N = 9


def _drop(drop_height: float, **values: float) -> np.ndarray:
    """Path (column, row, z, t) of one particle dropped at the centre of a flat plane at z = 0."""
    grid = Grid.full((N, N), DX)
    params = ParticleParams(drop_height=drop_height, k_eps=0.0, **values)
    result = run(HeightfieldTerrain(np.zeros((N, N)), grid), params,
                 Emission.source(1, (N // 2, N // 2)), paths=1)
    return result.paths[0].points


def test_fall_follows_the_stokes_solution_and_reaches_the_settling_speed():
    radius, rho_p, mu, g = 20.0, 1000.0, 4.4e4, 9.81
    z0 = 600.0
    points = _drop(z0, radius=radius, density=rho_p, mu_air=mu, rho_air=1.0, gravity=g, lifetime=120.0)
    w_s = 2.0 / 9.0 * g * radius**2 * (rho_p - 1.0) / mu  # 003 Eq. 7, f = 1 (empty particle)
    tau = 2.0 * rho_p * radius**2 / (9.0 * mu)  # Stokes relaxation time
    t, z = points[:, 3], points[:, 2]
    falling = np.arange(z.size) < np.argmax(z <= 0.0)  # before the first impact
    analytic = z0 - w_s * t + w_s * tau * -np.expm1(-t / tau)
    # the integrator is exact for a uniform medium: only rounding separates the two
    assert np.max(np.abs(z[falling] - analytic[falling])) < 1e-9 * z0
    late = falling & (t > 10 * tau)
    speed = -np.diff(z[late]) / np.diff(t[late])
    assert np.all(np.abs(speed / w_s - 1.0) < 1e-4)  # e^-10 of the start speed is left


@pytest.mark.parametrize("restitution", [0.3, 0.6, 0.9])
def test_bounce_height_scales_with_the_square_of_the_restitution(restitution):
    h0, dt = 20.0, 0.005
    # real air viscosity: drag is negligible (τ_s = 2ρR²/(9μ) ≈ 1e7 s against a flight of ~4 s)
    points = _drop(h0, radius=1.0, restitution=restitution, mu_air=1.8e-5, dt=dt, lifetime=5.0,
                   rest_speed=0.0)
    t, z = points[:, 3], points[:, 2]
    first = np.argmax(z <= 0.0)
    assert t[first] == pytest.approx(math.sqrt(2 * h0 / 9.81), abs=dt)
    h1 = z[first:].max()
    # Errors: the apex is sampled every step (≤ g·dt²/8 = 3e-5 m low) and the impact is placed
    # by linear interpolation of the quadratic fall within one step, so the rebound speed is
    # off by ≤ g·dt/2 out of √(2gh0) = 19.8 m/s (≤ 0.13 %, i.e. ≤ 0.25 % on the height).
    assert h1 / h0 == pytest.approx(restitution**2, rel=2.5e-3)


def test_terrain_interface_gives_depth_and_normal_of_a_plane():
    grid = Grid.full((N, N), DX)
    terrain = HeightfieldTerrain(0.5 * DX * np.arange(N)[None, :].repeat(N, axis=0), grid)  # z = 0.5 x
    points = np.array([[30.0, 50.0, 10.0], [71.0, 13.0, 40.0]])
    assert np.allclose(terrain.depth(points), [15.0 - 10.0, 35.5 - 40.0], rtol=0, atol=1e-12)
    expected = np.array([-0.5, 0.0, 1.0]) / math.sqrt(1.25)
    assert np.allclose(terrain.normal(points[:, :2]), expected, rtol=0, atol=1e-12)
