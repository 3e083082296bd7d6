"""Rain on a cone (003 §5 Rain, Fig. 7): the flanks are eroded and the sediment comes to rest
at the foot; below sea level the particles are slowed and leave their load near the shore."""

from __future__ import annotations

import numpy as np
import pytest

from unerode_cli.grid import Grid
from unerode_cli.particles import Emission, HeightfieldTerrain, preset_params, run

DX = 20.0
N = 96
CONE_RADIUS = 500.0  # m
CONE_HEIGHT = 300.0  # m


@pytest.fixture(scope="module")
def cone():
    yy, xx = (np.mgrid[0:N, 0:N] - N / 2.0) * DX
    r = np.hypot(xx, yy)
    z = np.maximum(0.0, CONE_HEIGHT * (1.0 - r / CONE_RADIUS))
    terrain = HeightfieldTerrain(z, Grid.full((N, N), DX))
    return terrain, r / CONE_RADIUS


def _rain(terrain, rho, sea_level=None):
    return run(terrain, preset_params("rain", DX), Emission.rain(4000, mask=rho < 1.0), iterations=2,
               seed=3, sea_level=sea_level, paths=300)


def test_rain_erodes_the_flanks_and_deposits_at_the_foot(cone):
    terrain, rho = cone
    result = _rain(terrain, rho)
    dh = result.dh
    flanks = (rho > 0.2) & (rho < 0.8)
    foot = (rho > 0.9) & (rho < 1.2)
    assert dh[flanks].mean() < -5.0  # measured -17.2 m
    assert dh[foot].mean() > 5.0  # measured +22.5 m
    # 90 % of the deposited volume lies in the ring at the foot (measured 99.9 %)
    gain = np.maximum(dh, 0.0)
    assert gain[foot].sum() > 0.9 * gain.sum()
    assert np.all(dh[rho > 1.5] == 0.0)  # nothing reaches far out on the plain


def test_underwater_particles_are_slowed_and_deposit_below_the_shore(cone):
    terrain, rho = cone
    sea = 0.4 * CONE_HEIGHT  # shore at 0.6 cone radius
    dry, wet = _rain(terrain, rho), _rain(terrain, rho, sea_level=sea)

    def travel(result):  # mean distance (m) from emission to death
        return np.mean([np.hypot(*(p.points[-1, :2] - p.points[0, :2])) * DX for p in result.paths])

    assert travel(wet) < 0.5 * travel(dry)  # measured 31 m against 169 m
    submerged = (rho > 0.6) & (rho < 0.8)  # the flank just below the shore
    # erosion (measured -17.0 m) turns into deposition (+7.1 m)
    assert dry.dh[submerged].mean() < 0.0 < wet.dh[submerged].mean()
    assert np.maximum(wet.dh[submerged], 0).sum() > 3.0 * np.maximum(dry.dh[submerged], 0).sum()
