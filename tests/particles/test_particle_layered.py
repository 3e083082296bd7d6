"""Layered terrains (003 §4.2): erodibility follows the material at the surface, and deposits
become the deposit material on top of the stack."""

from __future__ import annotations

import numpy as np

from unerode_cli.grid import Grid
from unerode_cli.particles import Emission, LayeredTerrain, Material, preset_params, run

DX = 20.0
N = 40
SOFT = Material("soft", k_eps=2.5)
HARD = Material("hard", k_eps=0.25, tau_c=1.0)
SAND = Material("sand", k_eps=2.5)


def _slope(top: int, bottom: int) -> LayeredTerrain:
    """A 0.3 slope down to a flat plain (the southern third), 60 m of material ``top`` over
    200 m of ``bottom`` (indices into the material table)."""
    grid = Grid.full((N, N), DX)
    surface = 50.0 + 0.3 * DX * np.maximum(0, 2 * N // 3 - np.mgrid[0:N, 0:N][0])
    thickness = np.stack([np.full((N, N), 200.0), np.full((N, N), 60.0)])
    return LayeredTerrain(surface - 260.0, thickness, [bottom, top], [SOFT, HARD, SAND], deposit_material=2,
                          grid=grid)


def _rain(terrain: LayeredTerrain):
    return run(terrain, preset_params("rain", DX, capacity=100.0), Emission.rain(3000), seed=2)


def test_soft_over_hard_erodes_faster_than_hard_over_soft():
    soft_top, hard_top = _rain(_slope(0, 1)), _rain(_slope(1, 0))
    # the top layer is never eroded through (max erosion measured 15 m < 60 m) ...
    assert -soft_top.dh.min() < 60.0
    # ... so only the surface material differs: K_ε 10× larger and τ_c 0 instead of 1 Pa
    assert soft_top.budget.detached > 5.0 * hard_top.budget.detached  # measured ratio 17.4


def test_deposits_are_the_deposit_material_on_top():
    terrain = _slope(0, 1)
    result = _rain(terrain)
    new = result.terrain
    deposit = new.thickness[-1]
    assert new.layer_material[-1] == 2 and terrain.thickness[-1].sum() == 0.0
    gained = result.dh > 1e-6
    assert gained.sum() > 20
    assert np.all(deposit[gained] > 0.0)
    assert np.all(new.surface_material()[deposit > 0.0] == 2)
    # the deposit layer holds what was deposited and not eroded again
    assert 0 < deposit.sum() * DX * DX <= result.budget.deposited
    # where the surface did not move, eroded soft material may have been replaced by sand
    same = np.abs(result.dh) < 1e-9
    assert np.allclose(new.thickness[1:, same].sum(axis=0), 60.0, rtol=0, atol=1e-8)
    assert np.array_equal(new.thickness[0], terrain.thickness[0])  # the hard base is never reached
