"""Shallow-ice approximation: slab velocity and the explicit diffusion stability limit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from unerode_cli.glacier import sia
from unerode_cli.grid import Grid

A, N_GLEN, RHO, G = 1e-16, 3.0, 910.0, 9.81


def test_slab_velocity_is_the_analytic_one():
    alpha = math.radians(0.5)
    grid = Grid.full((3, 5), 1000.0, 700.0)
    flow = sia.velocity(np.zeros((3, 5)), np.full((3, 5), 1000.0), grid, A, N_GLEN, RHO, G,
                        boundary="periodic", background_slope=alpha)
    u_s = 2 * A / (N_GLEN + 1) * (RHO * G * math.sin(alpha)) ** N_GLEN * 1000.0 ** (N_GLEN + 1)
    assert u_s == pytest.approx(23.64, abs=0.005)
    np.testing.assert_allclose(flow.u_surface, u_s, rtol=2e-4)  # tan α vs sin α: 1.1e-4
    np.testing.assert_allclose(flow.u_mean, u_s * (N_GLEN + 1) / (N_GLEN + 2), rtol=2e-4)
    np.testing.assert_allclose(flow.diffusivity, flow.u_mean * 1000.0 / math.tan(alpha), rtol=1e-12)
    assert np.abs(flow.v_surface).max() == 0.0


def _ftcs_growth(d: float, grid: Grid, dt: float, steps: int = 400) -> float:
    """Amplitude ratio of the checkerboard (the fastest mode) after explicit diffusion steps."""
    y, x = np.mgrid[0:8, 0:8]
    h = (-1.0) ** (x + y)
    for _ in range(steps):
        lap = ((np.roll(h, 1, 1) + np.roll(h, -1, 1) - 2 * h) / grid.dx**2
               + (np.roll(h, 1, 0) + np.roll(h, -1, 0) - 2 * h) / grid.dy**2)
        h = h + dt * d * lap
    return float(np.abs(h).max())


@pytest.mark.parametrize(("dx", "dy"), [(100.0, 100.0), (100.0, 40.0)])
def test_stability_limit_is_the_explicit_diffusion_limit(dx, dy):
    grid = Grid.full((8, 8), dx, dy)
    d = np.array([[0.0, 3.0e3], [1.0e3, 5.0e2]])  # m²/y, D_max = 3000
    dt = sia.max_stable_dt(d, grid, c=1.0)
    if dx == dy:
        assert dt == pytest.approx(dx**2 / (4 * 3.0e3), rel=1e-12)
    assert _ftcs_growth(3.0e3, grid, 0.99 * dt) <= 1.0
    assert _ftcs_growth(3.0e3, grid, 1.02 * dt) > 10.0
    assert sia.max_stable_dt(d, grid) == pytest.approx(0.5 * dt, rel=1e-12)
    assert sia.max_stable_dt(np.zeros((2, 2)), grid) == math.inf
